"""Number, period and title formatting shared by every figure."""

from __future__ import annotations

import math

import pytest

from analysis.configs import describe
from analysis.style import number, period, wrap


@pytest.mark.parametrize("value, text", [(20.0, "20"), (12.5, "12.5"), (math.nan, "-"),
                                         (None, "-"), ("mser", "mser")])
def test_number(value, text):
    assert number(value) == text


@pytest.mark.parametrize("us, text", [(500.0, "500 µs"), (1000.0, "1 ms"), (2500.0, "2.5 ms"),
                                      (50.0, "50 µs"), (1250.0, "1250 µs")])
def test_period(us, text):
    assert period(us) == text


def test_wrap_breaks_between_list_items_only():
    text = "Title — RT mser / nRT mser, self-sampling 1 ms, regulation 5 ms, threshold 30 %"
    lines = wrap(text, 40).split("\n")
    assert all(len(line) <= 40 for line in lines)
    assert "threshold 30 %" in lines[-1] and "regulation 5 ms," in lines[-2]


def test_wrap_keeps_explicit_lines_and_splits_long_parts_at_spaces():
    assert wrap("a\nb", 10) == "a\nb"
    assert all(len(line) <= 12 for line in wrap("word " * 10, 12).split("\n"))


def test_describe_words_of_the_paper():
    config = {"rt_workload": "mser", "nrt_workload": "bandwidth_read", "policy": "interval",
              "sampling": "self", "sampling_period_us": 1000.0,
              "regulation_period_us": 5000.0, "threshold_pct": 20.0}
    assert describe(config) == ("RT mser / nRT bandwidth_read, interval-based regulation, "
                                "self-sampling 1 ms, regulation 5 ms, threshold 20 %")
    assert describe({"sampling": "external", "sampling_period_us": 500.0}, short=True) \
        == "external 500 µs"
    assert describe({"rt_workload": None, "nrt_workload": "bandwidth_read"}) \
        == "nRT bandwidth_read alone"

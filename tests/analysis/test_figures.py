"""The figure registry picks exactly the figures each experiment supports, and each figure
kind draws what a reader of the paper expects (labels with units, legends, isolation line,
error bars, ▽ × △ markers, log sampling-period axis, grid layout)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from matplotlib.container import BarContainer, ErrorbarContainer

import resultgen
from analysis.figures import isolation, plan_figures
from analysis.results import load_results

DELAY = "activation_delay_vs_sampling_period"
CALLBACK = "pmc_callback_vs_sampling_period"

EXPECTED = {
    "threshold": {"slowdown_vs_threshold", DELAY, CALLBACK, "tradeoff",
                  "mechanisms_bandwidth_read", "mechanisms_mser"},
    "regulation": {"slowdown_vs_regulation_period", "tradeoff"},
    "sampling": {"slowdown_vs_threshold", "slowdown_vs_sampling_period", DELAY, CALLBACK,
                 "tradeoff"},
    "delay": {"slowdown_vs_sampling_period", DELAY, CALLBACK, "tradeoff", "mechanisms"},
    "overhead": {"sampling_overhead_vs_sampling_period", CALLBACK},
    "grid": {"rt_nrt_grid_threshold15", "rt_nrt_grid_threshold20", "rt_nrt_grid_threshold30",
             DELAY, CALLBACK, "tradeoff", "mechanisms_bandwidth_read",
             "mechanisms_bandwidth_write", "mechanisms_mser"},
    "memguard": {"slowdown_vs_threshold", "rt_nrt_grid_threshold20",
                 "rt_nrt_grid_threshold30", "rt_nrt_grid_threshold40", DELAY, CALLBACK,
                 "tradeoff", "mechanisms"},
    "mechanisms": {"slowdown_vs_threshold", "rt_nrt_grid_threshold20",
                   "rt_nrt_grid_threshold30", "rt_nrt_grid_threshold40", DELAY, CALLBACK,
                   "tradeoff", "mechanisms"},
    "tune": {"slowdown_vs_threshold", "slowdown_vs_sampling_period", DELAY, CALLBACK,
             "tradeoff", "mechanisms"},
    "rt_alone": {"isolation_table1"},
}


def _plans(results):
    plans, _ = plan_figures(results)
    return {p.stem: p for p in plans}


def _skipped(results):
    return {s.kind: s.reason for s in plan_figures(results)[1]}


def _texts(fig):
    """Every text of a figure: suptitle, titles, labels, legend entries, notes."""
    out = [t.get_text() for t in fig.texts]
    if fig._suptitle is not None:
        out.append(fig._suptitle.get_text())
    for legend in fig.legends:
        out += [t.get_text() for t in legend.get_texts()]
    for ax in fig.axes:
        out += [ax.get_title(), ax.get_xlabel(), ax.get_ylabel()]
        if ax.get_legend():
            out += [t.get_text() for t in ax.get_legend().get_texts()]
    return "\n".join(out)


def _legend_labels(fig):
    return [t.get_text() for legend in fig.legends for t in legend.get_texts()]


def _has_isolation_line(ax):
    return any(list(line.get_ydata()) == [1.0, 1.0] and line.get_linestyle() == "--"
               for line in ax.get_lines())


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_registry_picks_exactly_the_supported_figures(loaded, name):
    assert set(_plans(loaded(name))) == EXPECTED[name]


@pytest.mark.parametrize("name, kind, words", [
    ("threshold", "slowdown vs sampling period", "no sampling-period sweep"),
    ("threshold", "RT x nRT grid", "nRT workload does not vary"),
    ("threshold", "sampling overhead vs sampling period", "no nRT-alone points"),
    ("sampling", "slowdown vs regulation period", "at a fixed sampling period"),
    ("regulation", "activation delay vs sampling period", "no activation_delay samples"),
    ("overhead", "slowdown vs threshold", "no points with an RT node"),
    ("grid", "slowdown vs threshold", "the RT x nRT grid figures show these points"),
    ("threshold", "isolation figures (Table 1)", "co-run points"),
])
def test_unsupported_figures_are_skipped_with_a_reason(loaded, name, kind, words):
    assert words in _skipped(loaded(name))[kind]


def test_every_plan_has_a_one_line_summary(loaded):
    for name in EXPECTED:
        for plan in _plans(loaded(name)).values():
            assert plan.summary and "\n" not in plan.summary


def test_slowdown_vs_threshold_compares_policies_per_workload_pair(loaded, drawn):
    fig = drawn(_plans(loaded("threshold"))["slowdown_vs_threshold"])
    assert len(fig.axes) == 4                        # 2 workload pairs x (RT, nRT)
    text = _texts(fig)
    for words in ("self-sampling 1 ms", "regulation 5 ms", "RT bandwidth_read / nRT "
                  "bandwidth_read", "RT mser / nRT mser", "RT slowdown (× isolation)",
                  "nRT slowdown (× isolation)", "threshold (% of reference bandwidth)",
                  "min–max over repetitions"):
        assert words in text
    assert {"interval", "monolithic", "isolation (1.0)"} <= set(_legend_labels(fig))
    for ax in fig.axes:
        assert _has_isolation_line(ax)
        bars = [c for c in ax.containers if isinstance(c, ErrorbarContainer)]
        assert len(bars) == 2 and all(c.has_yerr for c in bars)
        assert [t for t in ax.get_xticks()] == [5, 10, 20, 30]


def test_slowdown_vs_threshold_plots_the_means(loaded, drawn):
    results = loaded("threshold")
    fig = drawn(_plans(results)["slowdown_vs_threshold"])
    nrt_panel = fig.axes[1]                          # row 0 (bandwidth_read), nRT
    interval = next(c for c in nrt_panel.containers if c.get_label() == "interval")
    xs, ys = interval.lines[0].get_data()
    expected = [p.mean("nrt_slowdown") for p in results.points
                if p.config["policy"] == "interval"
                and p.config["rt_workload"] == "bandwidth_read"]
    assert list(xs) == [5, 10, 20, 30]
    assert np.allclose(ys, expected)


def test_slowdown_vs_sampling_period_has_a_log_axis_and_states_the_tied_period(loaded, drawn):
    fig = drawn(_plans(loaded("sampling"))["slowdown_vs_sampling_period"])
    assert all(ax.get_xscale() == "log" for ax in fig.axes)
    assert "regulation period = 5 × sampling period" in _texts(fig)
    assert "sampling period (µs)" in _texts(fig)
    assert {f"threshold {t} %" for t in (5, 10, 20, 30)} <= set(_legend_labels(fig))


def test_slowdown_vs_sampling_period_self_vs_external(loaded, drawn):
    fig = drawn(_plans(loaded("delay"))["slowdown_vs_sampling_period"])
    assert {"self", "external"} <= set(_legend_labels(fig))


def test_slowdown_vs_regulation_period(loaded, drawn):
    fig = drawn(_plans(loaded("regulation"))["slowdown_vs_regulation_period"])
    assert len(fig.axes) == 4
    text = _texts(fig)
    assert "regulation period (µs)" in text and "self-sampling 500 µs" in text
    assert "threshold 30 %" in text
    assert list(fig.axes[0].get_xticks()) == [1000, 2000, 3000, 4000, 5000]


def test_activation_delay_shows_min_median_max_self_vs_external(loaded, drawn):
    results = loaded("delay")
    fig = drawn(_plans(results)[DELAY])
    ax = fig.axes[0]
    assert ax.get_xscale() == "log" and ax.get_ylabel() == "activation delay (µs)"
    assert {"self-sampling", "external-sampling", "min", "median", "max"} \
        <= set(_legend_labels(fig))
    markers = {}
    for line in ax.get_lines():
        if len(line.get_xdata()) == 1:
            markers.setdefault((line.get_color(), line.get_marker()), []).append(
                (line.get_xdata()[0], line.get_ydata()[0]))
    # ▽ × △ for each of 5 sampling periods, in two colours (self, external)
    assert sorted(len(v) for v in markers.values()) == [5] * 6
    self_1ms = np.concatenate([results.samples_of(p.id, "activation_delay")
                               for p in results.points
                               if p.config["sampling"] == "self"
                               and p.config["sampling_period_us"] == 1000])
    medians = [y for (colour, m), pts in markers.items() if m == "x"
               for x, y in pts if 900 < x < 1000]      # self is drawn just left of 1000
    assert medians == [pytest.approx(np.median(self_1ms))]


def test_distributions_state_what_is_pooled(loaded, drawn):
    fig = drawn(_plans(loaded("threshold"))[CALLBACK])
    text = _texts(fig)
    assert "PMC callback duration (µs)" in text
    assert "pooled over" in text and "threshold 5–30" in text


def test_rt_nrt_grid_layout(loaded, drawn):
    results = loaded("grid")
    fig = drawn(_plans(results)["rt_nrt_grid_threshold20"])
    axes = fig.axes
    assert len(axes) == 3 * 4                        # RT workloads x nRT workloads
    assert [ax.get_title() for ax in axes[:4]] == [
        "nRT bandwidth_read", "nRT disparity", "nRT mser", "nRT sift"]
    assert axes[0].get_ylabel().startswith("RT mser") and axes[4].get_ylabel().startswith(
        "RT bandwidth_read")
    assert _legend_labels(fig) == ["self 1 ms", "external 1 ms", "external 500 µs",
                                   "isolation (1.0)", "unregulated co-run"]
    assert "threshold 20 %" in _texts(fig) and "regulation 5 ms" in _texts(fig)
    cell = axes[0]                                   # RT mser / nRT bandwidth_read
    bars = [b for c in cell.containers if isinstance(c, BarContainer) for b in c]
    assert len(bars) == 2 * 3                        # (RT, nRT) x 3 configurations
    point = next(p for p in results.points
                 if p.config["rt_workload"] == "mser"
                 and p.config["nrt_workload"] == "bandwidth_read"
                 and p.config["threshold_pct"] == 20 and p.config["sampling"] == "self")
    nrt_self = bars[3]                               # nRT cluster, first configuration
    assert nrt_self.get_y() == 1.0
    assert nrt_self.get_height() == pytest.approx(point.mean("nrt_slowdown") - 1.0)
    assert all(_has_isolation_line(ax) for ax in axes)


def test_sampling_overhead_shows_slowdown_and_cost_per_sample(loaded, drawn):
    fig = drawn(_plans(loaded("overhead"))["sampling_overhead_vs_sampling_period"])
    slowdown, per_sample = fig.axes
    assert slowdown.get_ylabel() == "nRT slowdown (× isolation)"
    assert per_sample.get_ylabel() == "sampling overhead per sample (µs)"
    assert slowdown.get_xscale() == "log" and _has_isolation_line(slowdown)
    assert {"self", "external", "min", "median", "max"} <= set(_legend_labels(fig))
    title = fig._suptitle.get_text()
    assert "nRT bandwidth_read alone" in title and "monitoring only" in title
    assert "threshold" not in title          # no budget without regulation


def test_many_groups_are_split_over_numbered_files(tmp_path):
    points = []
    for w in ("bandwidth_read", "bandwidth_write", "mser", "sift", "stitch"):
        points += resultgen.sweep({"rt_workload": w, "nrt_workload": w},
                                  {"nodes.rt[0].workload": [w],
                                   "regulation.threshold_pct": [10, 20]})
    results = load_results(resultgen.write_results(tmp_path / "five", points, reps=1))
    plans = _plans(results)
    assert {"slowdown_vs_threshold_1", "slowdown_vs_threshold_2"} <= set(plans)
    assert "part 2 of 2" in plans["slowdown_vs_threshold_2"].summary


def test_isolation_figures_sit_beside_the_paper_table1(loaded, drawn):
    results = loaded("rt_alone")
    figures = isolation.isolation_figures(results)
    refs = isolation.references(results)
    assert set(figures) == {"mser", "sift"}
    assert refs["mser"]["ipc"] == 2.16 and refs["sift"]["mbps"] == 232.15
    fig = drawn(_plans(results)["isolation_table1"])
    ipc_ax, bw_ax = fig.axes[:2]
    assert ipc_ax.get_ylabel() == "IPC (instructions per cycle)"
    assert bw_ax.get_ylabel() == "bandwidth, Eq. 1 (MB/s)" and bw_ax.get_yscale() == "log"
    # one bar per workload, at the measured mean
    assert [round(b.get_height(), 6) for b in ipc_ax.patches] == [
        round(figures[w]["ipc"], 6) for w in ("mser", "sift")]
    assert "reference (Table 1)" in _texts(fig)
    # the error against the reference is written over each bar
    errors = [t.get_text() for t in ipc_ax.texts]
    assert errors == [f"{isolation.error_pct(figures[w]['ipc'], refs[w]['ipc']):+.2f} %"
                      if abs(isolation.error_pct(figures[w]['ipc'], refs[w]['ipc'])) < 1 else
                      f"{isolation.error_pct(figures[w]['ipc'], refs[w]['ipc']):+.1f} %"
                      for w in ("mser", "sift")]


def test_isolation_error_in_percent():
    assert isolation.error_pct(2.2, 2.0) == pytest.approx(10.0)
    assert math.isnan(isolation.error_pct(2.2, None))


def test_isolation_without_references_draws_the_measured_bars_only(tmp_path, drawn):
    from analysis.results import load_results
    folder = resultgen.write_results(tmp_path / "noref", resultgen.rt_alone_points(),
                                     references=False)
    results = load_results(folder)
    assert isolation.references(results) == {}
    fig = drawn(_plans(results)["isolation_table1"])
    assert "reference (Table 1)" not in _texts(fig)

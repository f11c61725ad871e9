"""tools/sensitivity.py: finding the guesses of a platform file and writing its variants."""

from __future__ import annotations

import importlib.util
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("sensitivity", ROOT / "tools" / "sensitivity.py")
sensitivity = importlib.util.module_from_spec(_spec)
sys.modules["sensitivity"] = sensitivity   # dataclasses look their module up there
_spec.loader.exec_module(sensitivity)

PLATFORM = {
    "name": "toy",
    "memory": {
        "l3": {"latency_ns": 20, "queue_ns": 8, "bandwidth_mbps": 60000,
               "source": "latency_ns: guess, plausible range 10-40 (why). queue_ns: measured on "
                         "the board. bandwidth_mbps: guess, plausible range 40000-120000"},
    },
    "costs": {
        "delay_us": {"dist": "normal", "mean_us": 10, "sd_us": 1, "min_us": 8, "max_us": 14,
                     "source": "guess, plausible range 5-30 (the mean)"},
        "other_us": {"dist": "normal", "mean_us": 15, "sd_us": 1,
                     "source": "paper; its spread is a guess"},
    },
}


def test_guesses_named_by_key_or_by_a_distribution_and_unranged_ones_listed():
    guesses, unranged = sensitivity.find_guesses(PLATFORM)
    assert [(g.name, g.base, g.low, g.high) for g in guesses] == [
        ("memory.l3.latency_ns", 20, 10, 40),
        ("memory.l3.bandwidth_mbps", 60000, 40000, 120000),
        ("costs.delay_us.mean_us", 10, 5, 30),
    ]
    assert unranged == ["costs.other_us"]


def test_a_guess_outside_its_range_is_refused():
    doc = json.loads(json.dumps(PLATFORM))
    doc["memory"]["l3"]["latency_ns"] = 50
    with pytest.raises(ValueError, match="memory.l3.latency_ns = 50 lies outside"):
        sensitivity.find_guesses(doc)


def test_a_variant_sets_one_number_and_scales_a_distribution_as_a_whole():
    guesses, _ = sensitivity.find_guesses(PLATFORM)
    by = {g.name: g for g in guesses}
    v = sensitivity.variant(PLATFORM, by["memory.l3.latency_ns"], 40)
    assert v["memory"]["l3"]["latency_ns"] == 40 and v["memory"]["l3"]["queue_ns"] == 8
    assert PLATFORM["memory"]["l3"]["latency_ns"] == 20            # the original is untouched
    d = sensitivity.variant(PLATFORM, by["costs.delay_us.mean_us"], 30)["costs"]["delay_us"]
    assert (d["mean_us"], d["sd_us"], d["min_us"], d["max_us"]) == (30, 3, 24, 42)


def test_changed_verdicts_are_named():
    base = {"5": False, "7a": True, "8a": False}
    assert sensitivity.describe({"5": False, "7a": True, "8a": False}, base) == "same"
    assert sensitivity.describe({"5": True, "7a": False, "8a": False}, base) == \
        "5 holds; 7a fails"


def test_the_orin_platform_sources_every_number_and_ranges_its_guesses():
    """Every guess of orin-agx.json lies in its plausible range, and no number is said to be
    chosen to reproduce a finding."""
    doc = json.loads((ROOT / "scenarios" / "platforms" / "orin-agx.json").read_text())
    guesses, _ = sensitivity.find_guesses(doc)
    assert len(guesses) >= 5

    def sources(obj):
        if isinstance(obj, dict):
            if "source" in obj:
                yield obj["source"]
            for v in obj.values():
                yield from sources(v)
    for s in sources(doc):
        assert not re.search(r"chosen so that|tuned|so that .* close to isolation", s), s


def test_a_variant_scenario_names_the_refitted_workload_files():
    scenario = {"nodes": {"controller": {"core": 0},
                          "rt": [{"name": "rt0", "core": 1, "workload": "mser"}],
                          "nrt": [{"name": "nrt0", "core": 2, "workload": "own.json"}]},
                "sweep": {"nodes.nrt[0].workload": ["sift", "mser", "latency"],
                          "regulation.threshold_pct": [20, 30]}}
    fitted = {"mser": Path("/v/mser.json"), "sift": Path("/v/sift.json")}
    s = sensitivity.use_workloads(scenario, fitted)
    assert s["nodes"]["rt"][0]["workload"] == "/v/mser.json"
    assert s["nodes"]["nrt"][0]["workload"] == "own.json"          # not a refitted one: kept
    assert s["sweep"]["nodes.nrt[0].workload"] == ["/v/sift.json", "/v/mser.json", "latency"]
    assert s["sweep"]["regulation.threshold_pct"] == [20, 30]


def test_a_page_without_markers_is_refused_before_anything_runs(tmp_path):
    page = tmp_path / "sensitivity.md"
    page.write_text("no markers\n")
    done = subprocess.run([sys.executable, str(ROOT / "tools" / "sensitivity.py"), "--doc",
                           str(page), "--rosguard", str(tmp_path / "no-rosguard"),
                           "--out", str(tmp_path / "out")], capture_output=True, text=True)
    assert done.returncode == 1
    assert f"{page}: expected one <!-- sensitivity:begin -->" in done.stderr
    assert not (tmp_path / "out").exists() and page.read_text() == "no markers\n"

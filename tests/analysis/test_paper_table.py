"""The strict paper checks of tools/paper_table.py on small results with chosen numbers.

Each check gets one results folder where the paper's statement holds and one where it does not;
the numbers are fixed per point (resultgen's ``fixed``), so every verdict is known in advance.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

import resultgen
from analysis.results import load_results

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("paper_table", ROOT / "tools" / "paper_table.py")
paper_table = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(paper_table)

SEVEN = ["bandwidth_read", "bandwidth_write", "disparity", "mser", "sift", "stitch", "tracking"]


def results(tmp_path, name, points, figures):
    """Writes the points, each with the figures ``figures(settings)`` returns, and loads them."""
    for s in points:
        s["fixed"] = figures(s)
    return load_results(resultgen.write_results(tmp_path / name, points, reps=2))


def verdicts(rows):
    return {n: ok for n, _, _, ok in rows}


# --- experiment 5 -------------------------------------------------------------------------

def test_crossover_splits_thresholds_into_no_help_and_help():
    assert paper_table.exp5_crossover({5: 0.01, 10: 0.02, 15: 0.08, 30: 0.2}) == (15, True)
    assert paper_table.exp5_crossover({5: 0.10, 10: 0.12, 15: 0.15}) == (5, True)
    assert paper_table.exp5_crossover({5: 0.10, 10: 0.01, 15: 0.15}) == (15, False)
    assert paper_table.exp5_crossover({5: 0.0, 10: 0.0}) == (None, False)


def sampling_points():
    periods = [{"sampling_period_us": sp, "regulation_period_us": 5 * sp} for sp in (250, 2000)]
    return resultgen.sweep({}, {"regulation": periods,
                                "regulation.threshold_pct": [5, 10, 15, 30]})


def test_exp5_holds_when_looser_sampling_helps_only_above_10_percent(tmp_path):
    def figures(s):
        loose = s["sampling_period_us"] == 2000
        t = s["threshold_pct"]
        nrt = 2.0 if t <= 10 else 1.4
        return {"rt_slowdown": 1.05, "nrt_slowdown": nrt * (0.85 if loose and t > 10 else 1.0)}
    rows = paper_table.exp5(results(tmp_path, "exp5", sampling_points(), figures))
    assert verdicts(rows) == {"5": True}
    assert "helps from 15 % up" in rows[0][2]


def test_exp5_fails_when_looser_sampling_helps_at_every_threshold(tmp_path):
    def figures(s):
        loose = s["sampling_period_us"] == 2000
        return {"rt_slowdown": 1.05, "nrt_slowdown": 2.0 * (0.85 if loose else 1.0)}
    rows = paper_table.exp5(results(tmp_path, "exp5", sampling_points(), figures))
    assert verdicts(rows) == {"5": False}
    assert "helps from 5 % up" in rows[0][2]
    assert "2.00 -> 1.70 (-15 %)" in rows[0][2]


# --- experiment 7 -------------------------------------------------------------------------

def grid_points():
    return resultgen.sweep({}, {"nodes.rt[0].workload": ["mser", "bandwidth_read"],
                                "nodes.nrt[0].workload": SEVEN,
                                "regulation.threshold_pct": [15, 30],
                                "regulation": resultgen.GRID_CONFIGURATIONS})


def paper_like_grid(s):
    """The grid as the paper describes it."""
    high = s["nrt_workload"] in paper_table.PAPER_HIGH_BW
    nrt = 3.0 if high else 1.1
    if s["sampling"] == "external":
        nrt -= 0.05
    rt = 1.04
    # external 500 us delays the RT node more with one high-bandwidth nRT node
    if (s["sampling_period_us"] == 500 and s["nrt_workload"] == "bandwidth_read"
            and s["rt_workload"] == "mser" and s["threshold_pct"] == 30):
        rt = 1.08
    return {"rt_slowdown": rt, "nrt_slowdown": nrt}


def test_exp7_holds_on_the_paper_like_grid(tmp_path):
    rows = paper_table.exp7(results(tmp_path, "exp7", grid_points(), paper_like_grid))
    assert verdicts(rows) == {"7a": True, "7b": True, "7c": True, "7d": True}
    by = {n: rep for n, _, rep, _ in rows}
    assert "high group {bandwidth_read, bandwidth_write, disparity}" in by["7b"]
    assert "1.080 vs 1.040" in by["7d"]


def test_exp7_fails_each_statement_on_a_grid_that_contradicts_it(tmp_path):
    def figures(s):
        f = paper_like_grid(s)
        if s["nrt_workload"] == "disparity":       # disparity behaves as a low-bandwidth nRT
            f["nrt_slowdown"] = 1.2
        if s["sampling_period_us"] == 500:          # 500 us always protects the RT node better
            f["rt_slowdown"] = 1.02
        if s["nrt_workload"] == "bandwidth_write":  # far from isolation with one nRT
            f["rt_slowdown"] = 1.3
        if s["sampling"] == "external":             # external costs the nRT node more
            f["nrt_slowdown"] += 0.2
        return f
    rows = paper_table.exp7(results(tmp_path, "exp7", grid_points(), figures))
    assert verdicts(rows) == {"7a": False, "7b": False, "7c": False, "7d": False}
    by = {n: rep for n, _, rep, _ in rows}
    assert "high group {bandwidth_read, bandwidth_write}" in by["7b"]
    assert "RT slowdown at most 1.300" in by["7a"]


def test_high_bandwidth_group_splits_at_the_largest_gap():
    high, low, gap = paper_table.high_bandwidth_group(
        {"a": 3.0, "b": 2.8, "c": 1.3, "d": 1.2, "e": 1.1})
    assert (high, low) == ({"a", "b"}, {"c", "d", "e"})
    assert gap == pytest.approx(2.8 / 1.3)


# --- experiment 8 -------------------------------------------------------------------------

MECHANISMS = [{"policy": "interval", "sampling": "self"},
              {"policy": "interval", "sampling": "external"},
              {"policy": "memguard", "sampling": "overflow"}]


def memguard_points(mechanisms=MECHANISMS, nrt=("disparity", "mser", "sift")):
    return resultgen.sweep({"rt_workload": "bandwidth_read", "sampling_period_us": 200,
                            "regulation_period_us": 1000},
                           {"nodes.nrt[0].workload": list(nrt),
                            "regulation.threshold_pct": [20, 30, 40],
                            "regulation": mechanisms})


def toy_exp8(s, self_cost=0.4, memguard_rt=1.05):
    """A toy exp. 8: a lower threshold slows the nRT node; self-sampling costs it 0.4."""
    nrt = 1.2 + 8.0 / s["threshold_pct"] + (self_cost if s["sampling"] == "self" else 0.0)
    rt = memguard_rt if s["policy"] == "memguard" else 1.05
    return {"rt_slowdown": rt, "nrt_slowdown": nrt, "throttle_count": 10}


def test_exp8_holds_when_the_threshold_changes_the_nrt_slowdown(tmp_path):
    rows = paper_table.exp8(results(tmp_path, "exp8", memguard_points(), toy_exp8))
    assert verdicts(rows) == {"8a": True, "8b": True, "8c": True, "8d": True}
    assert "9 of 9 series differ" in rows[0][2]
    assert "MemGuard 1.050" in rows[2][2]
    assert "ROSGuard self above MemGuard in 3 of 3" in rows[3][2]


def test_exp8_fails_when_every_threshold_gives_the_same_run(tmp_path):
    def figures(s):
        return {"rt_slowdown": 1.05, "nrt_slowdown": 1.5 if s["sampling"] == "self" else 1.45,
                "throttle_count": 0}
    rows = paper_table.exp8(results(tmp_path, "exp8", memguard_points(), figures))
    assert verdicts(rows)["8a"] is False
    assert verdicts(rows)["8b"] is False
    assert "0 of 9 series differ" in rows[0][2]
    assert "0 throttles" in rows[0][2]
    # Nothing throttled: the comparison says these are unregulated co-runs.
    assert "no mechanism throttled at any point" in rows[2][2]


def test_exp8_memguard_comparison_fails_with_numbers(tmp_path):
    # MemGuard protects the RT node far better (1.05 vs 1.30), and ROSGuard self-sampling costs
    # the nRT node nothing more than MemGuard: 8c and 8d do not hold, and say by how much.
    def figures(s):
        return toy_exp8(s, self_cost=0.0, memguard_rt=1.05 / 1.3)
    rows = paper_table.exp8(results(tmp_path, "exp8", memguard_points(), figures))
    v = verdicts(rows)
    assert v["8c"] is False and v["8d"] is False
    assert "+30.0 %" in rows[2][2]
    assert "ROSGuard self above MemGuard in 0 of 3" in rows[3][2]


def test_exp8_without_memguard_points_says_so(tmp_path):
    rows = paper_table.exp8(results(tmp_path, "exp8", memguard_points(MECHANISMS[:2]), toy_exp8))
    v = verdicts(rows)
    assert v == {"8a": True, "8b": True, "8c": False, "8d": False}
    assert "no MemGuard points" in rows[2][2]


# --- experiment 4 -------------------------------------------------------------------------

def setpoint_points():
    points = []
    for w in ("bandwidth_read", "mser"):
        points += resultgen.sweep({"rt_workload": w, "nrt_workload": w},
                                  {"nodes.rt[0].workload": [w],
                                   "regulation.threshold_pct": [5, 10, 30],
                                   "regulation.policy": ["interval", "monolithic"]})
    return points


def paper_like_setpoint(s):
    t, mono = s["threshold_pct"], s["policy"] == "monolithic"
    nrt = {5: 8.0, 10: 8.0, 30: 2.8}[t] * (2.0 if mono else 1.0)
    rt = 1.1 + 0.01 * t
    # resultgen's RT time is 3 jobs of 20 ms: 60 ms x slowdown / 5 ms intervals
    intervals = 3 * resultgen.ISOLATION[s["rt_workload"]][0] * rt / 5000
    return {"rt_slowdown": rt, "nrt_slowdown": nrt, "throttle_count": round(intervals)}


def test_exp4_holds_on_the_paper_like_setpoint_sweep(tmp_path):
    rows = paper_table.exp4(results(tmp_path, "exp4", setpoint_points(), paper_like_setpoint))
    assert verdicts(rows) == {"4a": True, "4b": True, "4c": True, "4d": True}


def test_exp4_fails_each_statement_that_the_numbers_contradict(tmp_path):
    def figures(s):
        f = paper_like_setpoint(s)
        f["rt_slowdown"] = 1.5 - 0.01 * s["threshold_pct"]      # lower threshold: RT worse
        if s["policy"] == "monolithic":
            f["nrt_slowdown"] = 1.2                             # monolithic penalises less
        elif s["threshold_pct"] == 10:
            f["nrt_slowdown"] = 4.0                             # no saturation at 10 %
        f["throttle_count"] = 3                                 # budget rarely spent at 30 %
        return f
    rows = paper_table.exp4(results(tmp_path, "exp4", setpoint_points(), figures))
    assert verdicts(rows) == {"4a": False, "4b": False, "4c": False, "4d": False}


# --- the gallery --------------------------------------------------------------------------

def test_gallery_copies_one_figure_per_experiment_linked_from_its_page(tmp_path):
    for folder, (figure, _) in paper_table.GALLERY.items():
        (tmp_path / "results" / folder / "figures").mkdir(parents=True)
        (tmp_path / "results" / folder / "figures" / figure).write_bytes(folder.encode())
    out = tmp_path / "docs" / "figures"
    text = paper_table.gallery(tmp_path / "results", out, tmp_path / "docs")
    assert (out / "exp7-grid.png").read_bytes() == b"exp7-grid"
    assert "![Exp. 7: RT x nRT grid at 20 %](figures/exp7-grid.png)" in text
    assert text.count("](figures/") == len(paper_table.GALLERY)
    assert "](docs/figures/table1.png)" in paper_table.gallery(tmp_path / "results", out, tmp_path)


# --- the results folder as a whole ------------------------------------------------------------

def test_missing_experiments_are_named_with_the_command_that_makes_them(tmp_path, capsys,
                                                                      monkeypatch):
    resultgen.write_results(tmp_path / "table1", resultgen.threshold_points(), reps=1)
    with pytest.raises(paper_table.InvalidInput) as e:
        paper_table.check_rows(tmp_path)
    assert "exp1-pmc-callback" in str(e.value) and "table1," not in str(e.value)
    assert "make reproduce" in str(e.value)
    monkeypatch.setattr("sys.argv", ["paper_table.py", str(tmp_path)])
    with pytest.raises(SystemExit) as exit_:
        paper_table.main()
    assert exit_.value.code == 2
    assert "exp8-memguard" in capsys.readouterr().err


def test_the_column_title_says_which_backend_platform_and_repetitions_ran(tmp_path):
    for i, (folder, _) in enumerate(paper_table.FINDINGS):
        resultgen.write_results(tmp_path / "sim" / folder, resultgen.threshold_points(),
                                reps=1 if i == 0 else 3)
        resultgen.write_results(tmp_path / "hw" / folder, resultgen.threshold_points(), reps=2,
                                backend="hw")
    sim = paper_table.what_ran(paper_table.load_experiments(tmp_path / "sim"))
    assert sim.startswith("the sim reproduces (") and sim.endswith(", 1-3 repetitions)")
    hw = paper_table.what_ran(paper_table.load_experiments(tmp_path / "hw"))
    assert hw.startswith("measured (hw) (") and hw.endswith(", 2 repetitions)")

"""`compare A B`: matching by point id, hand-computed errors, outputs, and clear errors."""

from __future__ import annotations

import csv
import io
import json
import math

import numpy as np
import pytest

import resultgen
from analysis import compare
from analysis.__main__ import main
from analysis.results import InvalidInput, load_results
from checks import assert_figure_files, run_cli

# Hand-computed case. Per point: [(rt_slowdown, nrt_slowdown) per repetition].
A_VALUES = {"p0000000001": [(1.0, 2.0)], "p0000000002": [(1.1, 3.0)],
            "p0000000003": [(1.2, 4.0)], "p00000000a4": [(1.5, 1.5)]}
B_VALUES = {"p0000000001": [(1.1, 2.0)], "p0000000002": [(1.1, 3.2), (1.1, 3.4)],
            "p0000000003": [(1.32, 3.6)], "p00000000b5": [(1.0, 1.0)]}
THRESHOLDS = {"p0000000001": 10, "p0000000002": 20, "p0000000003": 30, "p00000000a4": 40,
              "p00000000b5": 50}


def write_hand(folder, values, backend):
    """A results folder with only the cells compare needs; the others are empty."""
    folder.mkdir(parents=True)
    header = resultgen.FIXED_COLUMNS + resultgen.EXTRA_COLUMNS
    with (folder / "points.csv").open("w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(header)
        for pid, reps in values.items():
            for rep, (rt, nrt) in enumerate(reps):
                cells = {"point": pid, "rep": rep, "backend": backend, "rt_workload": "mser",
                         "nrt_workload": "mser", "policy": "interval", "sampling": "self",
                         "scope": "core", "threshold_pct": THRESHOLDS[pid],
                         "sampling_period_us": 1000, "regulation_period_us": 5000,
                         "rt_slowdown": rt, "nrt_slowdown": nrt, "platform": "orin-agx"}
                w.writerow([cells.get(c, "") for c in header])
    (folder / "manifest.json").write_text(json.dumps(
        {"schema_version": 1, "backend": backend, "status": "complete"}))
    return folder


@pytest.fixture
def hand_pair(tmp_path):
    return (write_hand(tmp_path / "measured", A_VALUES, "hw"),
            write_hand(tmp_path / "simulated", B_VALUES, "sim"))


@pytest.mark.parametrize("x, y, expected", [
    ([1, 2, 3, 4], [10, 20, 30, 40], 1.0),
    ([1, 2, 3, 4], [4, 3, 2, 1], -1.0),
    ([1, 2, 3], [1.1, 1.1, 1.32], 1.5 / math.sqrt(2 * 1.5)),    # ties: ranks 1.5, 1.5, 3
])
def test_spearman(x, y, expected):
    assert compare.spearman(x, y) == pytest.approx(expected)


@pytest.mark.parametrize("x, y", [([1.0], [2.0]), ([1, 2, 3], [5, 5, 5])])
def test_spearman_undefined(x, y):
    assert math.isnan(compare.spearman(x, y))


def test_hand_computed_errors(hand_pair):
    comp = compare.compare_results(*(load_results(f) for f in hand_pair))
    assert [pa.id for pa, _ in comp.common] == ["p0000000001", "p0000000002", "p0000000003"]
    assert [p.id for p in comp.only_a] == ["p00000000a4"]
    assert [p.id for p in comp.only_b] == ["p00000000b5"]
    rt, nrt = comp.errors["rt"], comp.errors["nrt"]
    # RT: B - A = 0.1, 0, 0.12 -> 10 %, 0 %, 10 %
    assert rt.pairs == 3
    assert rt.mape_pct == pytest.approx(20.0 / 3)
    assert rt.max_abs_error == pytest.approx(0.12) and rt.max_abs_error_point == "p0000000003"
    assert rt.mean_error == pytest.approx(0.22 / 3)
    assert rt.spearman == pytest.approx(0.8660254)
    # nRT: B (means over repetitions) = 2.0, 3.3, 3.6 -> 0 %, 10 %, 10 %
    assert nrt.mape_pct == pytest.approx(20.0 / 3)
    assert nrt.max_abs_error == pytest.approx(0.4) and nrt.max_abs_error_point == "p0000000003"
    assert nrt.mean_error == pytest.approx(-0.1 / 3)
    assert nrt.spearman == pytest.approx(1.0)
    assert comp.mismatches == []


def test_outputs_table_summary_and_scatter(hand_pair, tmp_path):
    stream = io.StringIO()
    assert compare.run(*hand_pair, tmp_path / "out", stream=stream) == 0
    out = tmp_path / "out"
    with (out / "compare.csv").open(newline="") as f:
        rows = {r["point"]: r for r in csv.DictReader(f)}
    assert [r["status"] for r in rows.values()] == ["both"] * 3 + ["only_a", "only_b"]
    p2 = rows["p0000000002"]
    assert (p2["reps_a"], p2["reps_b"]) == ("1", "2")
    assert float(p2["nrt_slowdown_b"]) == pytest.approx(3.3)
    assert float(p2["nrt_diff"]) == pytest.approx(0.3)
    assert float(p2["nrt_error_pct"]) == pytest.approx(10.0)
    assert rows["p00000000a4"]["rt_slowdown_b"] == "" and rows["p00000000a4"]["rt_slowdown_a"]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["common_points"] == 3
    assert summary["only_in_a"] == ["p00000000a4"] and summary["only_in_b"] == ["p00000000b5"]
    assert summary["rt"]["mape_pct"] == pytest.approx(20.0 / 3)
    assert summary["nrt"]["spearman"] == pytest.approx(1.0)
    assert summary["a"]["backend"] == "hw" and summary["b"]["backend"] == "sim"
    assert_figure_files(out, "compare_scatter")
    printed = stream.getvalue()
    assert "common points: 3; only in A: 1 (p00000000a4); only in B: 1 (p00000000b5)" \
        in printed
    assert "6.667 %" in printed and "0.866" in printed


def test_generated_sim_vs_hw_pair_with_points_missing_on_each_side(tmp_path):
    points = resultgen.threshold_points()
    hw = resultgen.write_results(tmp_path / "hw", points, backend="hw", seed=2, drop=(3,))
    sim = resultgen.write_results(tmp_path / "sim", points, backend="sim", bias=1.1,
                                  drop=(5, 11))
    stream = io.StringIO()
    assert compare.run(hw, sim, stream=stream) == 0          # default out: B/compare
    summary = json.loads((sim / "compare" / "summary.json").read_text())
    ids = [resultgen.point_id(p["params"]) for p in points]
    assert summary["only_in_a"] == [ids[5], ids[11]]
    assert summary["only_in_b"] == [ids[3]]
    assert summary["common_points"] == 13
    assert summary["nrt"]["mean_error"] > 0                  # B over-predicts by design
    assert summary["nrt"]["spearman"] > 0.9
    assert_figure_files(sim / "compare", "compare_scatter")


def test_points_that_match_by_id_but_differ_in_settings_are_reported(tmp_path):
    points = resultgen.threshold_points()
    other = [{**p, "nrt_workload": "sift"} for p in points]   # same sweep, other scenario
    a = resultgen.write_results(tmp_path / "a", points)
    b = resultgen.write_results(tmp_path / "b", other)
    err = io.StringIO()
    assert compare.run(a, b, stream=io.StringIO(), err=err) == 0
    assert "differ in their settings" in err.getvalue() and "nrt_workload" in err.getvalue()
    summary = json.loads((b / "compare" / "summary.json").read_text())
    assert len(summary["settings_mismatch"]) == len(points)


def test_no_common_point_is_invalid_input(results_dir):
    with pytest.raises(InvalidInput, match="share no point"):
        compare.run(results_dir("threshold"), results_dir("grid"), stream=io.StringIO())


def test_no_common_point_exit_code(results_dir, tmp_path, capsys):
    args = ["compare", str(results_dir("threshold")), str(results_dir("overhead")),
            "--out", str(tmp_path)]
    assert main(args) == 2
    assert "share no point" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())                       # nothing written


@pytest.mark.parametrize("side", ["a", "b"])
def test_not_a_results_folder_on_either_side(results_dir, tmp_path, capsys, side):
    bogus = tmp_path / "bogus"
    bogus.mkdir()
    (bogus / "manifest.json").write_text("{}")
    good = str(results_dir("threshold"))
    args = [good, str(bogus)] if side == "b" else [str(bogus), good]
    assert main(["compare", *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and str(bogus) in err and "missing points.csv" in err


def test_cli_compare_as_rosguard_runs_it(hand_pair, tmp_path):
    done = run_cli("compare", *hand_pair, "--out", tmp_path)
    assert done.returncode == 0, done.stderr
    assert "RT" in done.stdout and "compare_scatter.png" in done.stdout
    done = run_cli("compare", hand_pair[0], tmp_path / "missing")
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert done.stderr.strip() == f"error: {tmp_path / 'missing'}: no such folder"


def test_error_summary_of_no_pairs():
    e = compare.error_summary([])
    assert e.pairs == 0 and math.isnan(e.mape_pct) and e.max_abs_error_point is None
    assert np.isnan(e.spearman)


def test_scatter_of_equal_repetitions_whose_mean_rounds_past_them(tmp_path):
    # A deterministic sim repeats its value exactly, and the loader's mean of 3 x 2.675 is
    # 2.6749999999999994 < min: an error bar of mean - min < 0 made matplotlib refuse the
    # scatter (the compare step of make validate).
    values = {"p0000000001": [(2.675, 2.675)] * 3, "p0000000002": [(1.2, 2.0)] * 3}
    a = write_hand(tmp_path / "a", values, "hw")
    b = write_hand(tmp_path / "b", values, "sim")
    stat = load_results(b).points[0].stat("rt_slowdown")
    assert stat.mean < stat.min                                    # the case is real
    assert compare.run(a, b, tmp_path / "out", stream=io.StringIO()) == 0
    assert_figure_files(tmp_path / "out", "compare_scatter")

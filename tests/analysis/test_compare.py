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


# The prediction band (--band): B's runs on two band platforms of its model. "high" lacks
# p0000000003 and p00000000b5 (a band run that did not finish).
BAND_VALUES = {
    "low": {"p0000000001": [(1.05, 1.9)], "p0000000002": [(1.0, 3.0)],
            "p0000000003": [(1.3, 3.5)], "p00000000b5": [(0.9, 1.0)]},
    "high": {"p0000000001": [(1.2, 2.1)], "p0000000002": [(1.15, 3.4), (1.15, 3.6)]},
}


@pytest.fixture
def band_folders(tmp_path):
    return [write_hand(tmp_path / "band" / name, values, "sim")
            for name, values in BAND_VALUES.items()]


def test_band_envelope_by_hand(hand_pair, band_folders):
    b = load_results(hand_pair[1])
    band = compare.prediction_band(b, [load_results(f) for f in band_folders])
    # p1: B 1.1 / 2.0, low 1.05 / 1.9, high 1.2 / 2.1; p2: B 1.1 / 3.3, low 1.0 / 3.0, high
    # 1.15 / 3.5 (mean of 3.4, 3.6); p3: B and low only; b5 (only in B): B and low.
    assert band.of("p0000000001", "rt") == pytest.approx((1.05, 1.2))
    assert band.of("p0000000001", "nrt") == pytest.approx((1.9, 2.1))
    assert band.of("p0000000002", "rt") == pytest.approx((1.0, 1.15))
    assert band.of("p0000000002", "nrt") == pytest.approx((3.0, 3.5))
    assert band.of("p0000000003", "rt") == pytest.approx((1.3, 1.32))
    assert band.of("p0000000003", "nrt") == pytest.approx((3.5, 3.6))
    assert band.of("p00000000b5", "rt") == pytest.approx((0.9, 1.0))
    assert all(math.isnan(v) for v in band.of("p00000000a4", "rt"))      # not a point of B
    assert band.missing == {str(band_folders[1]): ["p0000000003", "p00000000b5"]}
    # Coverage of A: RT 1.0 (out), 1.1 (in), 1.2 (out); nRT 2.0 (in), 3.0 (in: the edge
    # counts), 4.0 (out). Widths RT 0.15, 0.15, 0.02; nRT 0.2, 0.5, 0.1.
    comp = compare.compare_results(load_results(hand_pair[0]), b)
    summary = compare.band_summary(comp, band)
    assert summary["rt"]["points"] == 3 and summary["rt"]["covered"] == 1
    assert summary["rt"]["coverage_pct"] == pytest.approx(100 / 3)
    assert summary["rt"]["median_width"] == pytest.approx(0.15)
    assert summary["nrt"]["covered"] == 2 and summary["nrt"]["median_width"] == pytest.approx(0.2)


def test_band_coverage_skips_what_has_no_band():
    c = compare.band_coverage([(1.0, 0.9, 1.1), (2.0, math.nan, math.nan), (math.nan, 1, 2),
                               (3.0, 3.5, 4.0)])
    assert (c["points"], c["covered"]) == (2, 1)
    assert c["coverage_pct"] == pytest.approx(50.0)
    assert c["median_width"] == pytest.approx(0.35)          # widths 0.2, 0.5
    empty = compare.band_coverage([])
    assert empty["points"] == 0 and math.isnan(empty["coverage_pct"])
    assert math.isnan(empty["median_width"])


def test_band_outputs_and_the_warning_for_a_folder_missing_points(hand_pair, band_folders,
                                                                  tmp_path):
    out = tmp_path / "out"
    done = run_cli("compare", *hand_pair, "--out", out, "--band", band_folders[0],
                   "--band", band_folders[1])
    assert done.returncode == 0, done.stderr
    with (out / "compare.csv").open(newline="") as f:
        reader = csv.DictReader(f)
        header = reader.fieldnames
        rows = {r["point"]: r for r in reader}
    assert header[header.index("rt_error_pct") + 1:header.index("rt_error_pct") + 3] == \
        ["rt_band_low_b", "rt_band_high_b"]
    assert header[-2:] == ["nrt_band_low_b", "nrt_band_high_b"]
    assert float(rows["p0000000002"]["nrt_band_high_b"]) == pytest.approx(3.5)
    assert float(rows["p0000000003"]["rt_band_low_b"]) == pytest.approx(1.3)
    assert float(rows["p00000000b5"]["rt_band_low_b"]) == pytest.approx(0.9)   # only in B
    assert rows["p00000000a4"]["rt_band_low_b"] == ""                            # only in A
    summary = json.loads((out / "summary.json").read_text())
    band = summary["band"]
    assert band["folders"] == [str(f) for f in band_folders]
    assert band["rt"] == {"points": 3, "covered": 1, "coverage_pct": pytest.approx(100 / 3),
                          "median_width": pytest.approx(0.15)}
    assert band["nrt"]["coverage_pct"] == pytest.approx(200 / 3)
    assert "one-at-a-time" in band["definition"]
    assert "RT   B's band covers A at 1 of 3 points, median width 0.150" in done.stdout
    assert "nRT  B's band covers A at 2 of 3 points, median width 0.200" in done.stdout
    assert (f"warning: band folder {band_folders[1]} lacks 2 of 4 point(s) (p0000000003, "
            "p00000000b5); their band is made from the folders that have them") in done.stderr
    assert_figure_files(out, "compare_scatter")


def test_scatter_draws_the_band_on_b_points(hand_pair, band_folders):
    a, b = load_results(hand_pair[0]), load_results(hand_pair[1])
    comp = compare.compare_results(a, b)
    band = compare.prediction_band(b, [load_results(f) for f in band_folders])
    fig = compare.scatter(comp, band)
    for ax in fig.axes:
        labels = ax.get_legend_handles_labels()[1]
        assert any("prediction band" in label for label in labels), labels
        assert len(ax.containers) == 2                     # the points' bars and the band's
        band_bars = ax.containers[1]
        segments = band_bars.lines[2][0].get_segments()
        assert len(segments) == 3                          # one per common point
    rt_segments = sorted((s[0][1], s[1][1]) for s in fig.axes[0].containers[1].lines[2][0]
                         .get_segments())
    assert rt_segments == [pytest.approx((1.0, 1.15)), pytest.approx((1.05, 1.2)),
                           pytest.approx((1.3, 1.32))]
    plain = compare.scatter(comp)
    assert not any("prediction band" in label for ax in plain.axes
                   for label in ax.get_legend_handles_labels()[1])


def test_no_band_leaves_the_outputs_as_they_were(hand_pair, tmp_path):
    stream = io.StringIO()
    assert compare.run(*hand_pair, tmp_path / "out", stream=stream, bands=[]) == 0
    header = (tmp_path / "out" / "compare.csv").read_text().splitlines()[0]
    assert header == ("point,status,rt_workload,nrt_workload,policy,sampling,scope,"
                      "threshold_pct,sampling_period_us,regulation_period_us,reps_a,reps_b,"
                      "rt_name,rt_slowdown_a,rt_slowdown_b,rt_diff,rt_error_pct,nrt_name,"
                      "nrt_slowdown_a,nrt_slowdown_b,nrt_diff,nrt_error_pct")
    assert "band" not in json.loads((tmp_path / "out" / "summary.json").read_text())
    assert "prediction band" not in stream.getvalue()


def test_a_band_folder_of_another_scenario_is_invalid_input(hand_pair, tmp_path):
    other = write_hand(tmp_path / "other", {"p00000000a4": [(1.0, 1.0)]}, "sim")
    done = run_cli("compare", *hand_pair, "--out", tmp_path / "out", "--band", other)
    assert done.returncode == 2 and "share no point" in done.stderr

"""rosguard compare: matching by point id, the error summary, missing points, errors."""

import csv
import io
import json

import pytest

import resultgen
from analysis import compare
from analysis.results import InvalidInput, NotAResultsFolder, load_results
from conftest import assert_pdf, png_size


def _two_point_folder(folder, rt, nrt, backend):
    """A minimal results folder with two points (ids pa, pb) and one repetition each."""
    points = [{"params": {"regulation.threshold_pct": t}, "rt_workload": "mser",
               "nrt_workload": "mser", "policy": "interval", "sampling": "self",
               "scope": "core", "threshold_pct": t, "sampling_period_us": 1000,
               "regulation_period_us": 5000} for t in (10, 20)]
    resultgen.write_results(folder, points, reps=1, backend=backend)
    rows = list(csv.DictReader((folder / "points.csv").open()))
    for row, r, n in zip(rows, rt, nrt):
        row["rt_slowdown"], row["nrt_slowdown"] = str(r), str(n)
    with (folder / "points.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]), lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    return folder


def test_errors_are_computed_as_stated(tmp_path):
    a = _two_point_folder(tmp_path / "a", rt=[1.0, 2.0], nrt=[3.0, 1.5], backend="hw")
    b = _two_point_folder(tmp_path / "b", rt=[1.1, 1.8], nrt=[1.5, 3.0], backend="sim")
    comp = compare.compare_results(load_results(a), load_results(b))
    rt, nrt = comp.errors["rt"], comp.errors["nrt"]
    assert rt.pairs == 2
    assert rt.mape_pct == pytest.approx((0.1 / 1.0 + 0.2 / 2.0) / 2 * 100)   # 10 %
    assert rt.max_abs_error == pytest.approx(0.2)
    assert rt.mean_error == pytest.approx((0.1 - 0.2) / 2)
    assert rt.spearman == pytest.approx(1.0)     # same order in A and B
    assert nrt.spearman == pytest.approx(-1.0)   # order reversed
    assert nrt.max_abs_error == pytest.approx(1.5)


def test_spearman_handles_ties_and_degenerate_input():
    assert compare.spearman([1, 2, 2, 3], [1, 2, 2, 3]) == pytest.approx(1.0)
    assert list(compare.rank([5, 1, 5])) == [2.5, 1.0, 2.5]
    assert compare.spearman([1], [2]) != compare.spearman([1], [2])   # NaN: one pair
    assert compare.spearman([1, 1], [1, 2]) != compare.spearman([1, 1], [1, 2])


def test_points_missing_on_either_side_are_listed_not_fatal(make_results, tmp_path):
    points = resultgen.threshold_points()
    a = make_results("a", points, reps=2, backend="hw", drop=[0])
    b = make_results("b", points, reps=2, backend="sim", drop=[1, 2], bias=1.2)
    out = tmp_path / "cmp"
    stream = io.StringIO()
    assert compare.run(a, b, out, stream=stream, err=io.StringIO()) == 0
    summary = json.loads((out / "summary.json").read_text())
    ids = [resultgen.point_id(p["params"]) for p in points]
    assert summary["only_in_b"] == [ids[0]]
    assert summary["only_in_a"] == [ids[1], ids[2]]
    assert summary["common_points"] == len(points) - 3
    assert summary["rt"]["mean_error"] > 0      # B over-predicts (bias 1.2)
    table = list(csv.DictReader((out / "compare.csv").open()))
    assert [r["status"] for r in table].count("both") == len(points) - 3
    assert {r["status"] for r in table} == {"both", "only_a", "only_b"}
    assert "only in A: 2" in stream.getvalue()
    width, height = png_size(out / "compare_scatter.png")
    assert width > 400 and height > 300
    assert_pdf(out / "compare_scatter.pdf")


def test_identical_folders_agree_perfectly(make_results, tmp_path):
    a = make_results("a", resultgen.grid_points(), reps=1, seed=3)
    comp = compare.compare_results(load_results(a), load_results(a))
    assert comp.errors["rt"].mape_pct == 0.0
    assert comp.errors["nrt"].spearman == pytest.approx(1.0)


def test_a_folder_that_is_not_a_results_folder_is_named(make_results, tmp_path):
    a = make_results("a", resultgen.threshold_points(), reps=1)
    with pytest.raises(NotAResultsFolder, match=str(tmp_path / "nothing")):
        compare.run(a, tmp_path / "nothing", tmp_path / "out", stream=io.StringIO())


def test_folders_without_a_common_point_are_invalid_input(make_results, tmp_path):
    a = make_results("a", resultgen.threshold_points(), reps=1)
    b = make_results("b", resultgen.regulation_points(), reps=1)
    with pytest.raises(InvalidInput, match="share no point"):
        compare.run(a, b, tmp_path / "out", stream=io.StringIO())

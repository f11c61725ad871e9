"""Loading a results folder: typed cells, aggregation over repetitions, clear errors."""

import math

import pytest

import resultgen
from analysis.results import InvalidInput, NotAResultsFolder, load_results


def test_cells_are_typed_and_empty_cells_mean_not_applicable(make_results):
    folder = make_results("overhead", resultgen.overhead_points(), reps=2)
    r = load_results(folder)
    row = r.rows[0]
    assert row["rt_workload"] is None                 # no RT node: text cell empty -> None
    assert math.isnan(row["rt_slowdown"])             # numeric cell empty -> NaN
    assert isinstance(row["nrt_slowdown"], float)
    assert isinstance(row["rep"], int)
    assert r.backend == "sim" and r.status == "complete"


def test_points_aggregate_their_repetitions(make_results):
    folder = make_results("threshold", resultgen.threshold_points(), reps=3)
    r = load_results(folder)
    assert len(r.points) == len(resultgen.threshold_points())
    p = r.points[0]
    assert p.reps == 3
    values = [row["rt_slowdown"] for row in r.rows if row["point"] == p.id]
    stat = p.stat("rt_slowdown")
    assert stat.n == 3
    assert stat.mean == pytest.approx(sum(values) / 3)
    assert (stat.min, stat.max) == (min(values), max(values))


def test_samples_are_grouped_by_point_and_kind(make_results):
    folder = make_results("delay", resultgen.delay_points(), reps=2)
    r = load_results(folder)
    pid = r.points[0].id
    delays = r.samples_of(pid, "activation_delay")
    assert delays.size == 2 * resultgen.SAMPLES_PER_RUN   # pooled over both repetitions
    assert r.samples_of(pid, "no_such_kind").size == 0
    assert {"activation_delay", "pmc_callback"} <= r.sample_kinds()


def test_a_missing_folder_is_not_a_results_folder(tmp_path):
    with pytest.raises(NotAResultsFolder, match="no such folder"):
        load_results(tmp_path / "nope")


def test_a_folder_without_points_says_what_is_missing_and_how_to_make_one(tmp_path):
    (tmp_path / "manifest.json").write_text("{}")
    with pytest.raises(NotAResultsFolder) as e:
        load_results(tmp_path)
    assert "missing points.csv" in str(e.value)
    assert "rosguard run" in str(e.value)


def test_a_bad_number_names_the_file_line_and_column(make_results):
    folder = make_results("bad", resultgen.threshold_points(), reps=1)
    lines = (folder / "points.csv").read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[2].split(",")
    cells[header.index("rt_slowdown")] = "fast"
    lines[2] = ",".join(cells)
    (folder / "points.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(InvalidInput, match=r"points.csv: line 3: column rt_slowdown: 'fast'"):
        load_results(folder)


def test_a_csv_without_the_fixed_columns_is_rejected(make_results):
    folder = make_results("cols", resultgen.threshold_points(), reps=1)
    (folder / "points.csv").write_text("point,rep\np1,0\n")
    with pytest.raises(InvalidInput, match="not a rosguard points.csv"):
        load_results(folder)


def test_an_unknown_manifest_schema_version_is_rejected(make_results):
    folder = make_results("version", resultgen.threshold_points(), reps=1)
    (folder / "manifest.json").write_text('{"schema_version": 99}')
    with pytest.raises(InvalidInput, match="schema_version 99"):
        load_results(folder)

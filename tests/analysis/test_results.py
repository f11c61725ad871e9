"""Loading results folders: typing, aggregation, samples, sweep parameters, clear errors."""

from __future__ import annotations

import csv
import json
import math
import shutil

import numpy as np
import pytest

import resultgen
from analysis.results import InvalidInput, NotAResultsFolder, load_results


def test_cells_are_typed_and_empty_cells_are_not_applicable(loaded):
    r = loaded("overhead")
    row = r.rows[0]
    assert isinstance(row["rep"], int)
    assert row["nrt_workload"] == "bandwidth_read"
    assert row["rt_workload"] is None                      # no RT node: empty text cell
    assert math.isnan(row["rt_slowdown"])                  # ... and empty numeric cell
    assert row["sampling_period_us"] == 50.0
    assert len(r.rows) == 12 * 3 and len(r.points) == 12
    assert r.backend == "sim" and r.platform == "orin-agx" and r.status == "complete"


def test_points_aggregate_their_repetitions(loaded):
    r = loaded("threshold")
    point = r.points[0]
    values = [row["nrt_slowdown"] for row in r.rows if row["point"] == point.id]
    s = point.stat("nrt_slowdown")
    assert point.reps == 3 and s.n == 3
    assert s.mean == pytest.approx(np.mean(values))
    assert (s.min, s.max) == (min(values), max(values))
    assert s.std == pytest.approx(np.std(values, ddof=1))
    assert point.stat("rt_slowdown") is not None and point.has_rt and point.has_nrt


def test_not_applicable_metrics_have_no_stat(loaded):
    point = loaded("overhead").points[0]
    assert point.stat("rt_slowdown") is None
    assert math.isnan(point.mean("rt_slowdown"))
    assert not point.has_rt and point.has_nrt


def test_samples_are_grouped_by_point_and_kind(loaded):
    r = loaded("delay")
    pid = r.points[0].id
    delays = r.samples_of(pid, "activation_delay")
    assert delays.size == 3 * resultgen.SAMPLES_PER_RUN   # every repetition
    assert r.samples_of(pid, "no_such_kind").size == 0
    assert "queue_depth" in r.sample_kinds()              # unknown kinds load, figures ignore


def test_missing_samples_file_means_no_samples(loaded):
    assert loaded("regulation").samples == {}


def test_redundant_sweep_parameters_are_not_extra_dimensions(loaded):
    config = loaded("grid").config_columns
    # nodes.*.workload, threshold and the quoted JSON "regulation" object repeat named columns
    assert not [c for c in config if c.startswith("param:")]
    assert {"rt_workload", "nrt_workload", "threshold_pct", "sampling"} <= set(config)


def test_sweep_parameter_without_a_column_is_a_dimension(tmp_path):
    points = resultgen.sweep({}, {"sim.quantum_us": [5, 10],
                                  "regulation.threshold_pct": [10, 20]})
    r = load_results(resultgen.write_results(tmp_path / "q", points))
    assert "param:sim.quantum_us" in r.config_columns
    assert "param:regulation.threshold_pct" not in r.config_columns
    assert {p.config["param:sim.quantum_us"] for p in r.points} == {5.0, 10.0}


def test_interrupted_run_loads_the_rows_written(tmp_path):
    folder = resultgen.write_results(tmp_path / "i", resultgen.threshold_points(),
                                     status="interrupted", drop=range(4, 16))
    r = load_results(folder)
    assert r.status == "interrupted" and len(r.points) == 4


def _copy(results_dir, tmp_path, name="threshold"):
    return shutil.copytree(results_dir(name), tmp_path / "copy")


def _rewrite_points(folder, edit):
    path = folder / "points.csv"
    with path.open(newline="") as f:
        lines = list(csv.reader(f))
    edit(lines)
    with path.open("w", newline="") as f:
        csv.writer(f, lineterminator="\n").writerows(lines)


def test_missing_folder(tmp_path):
    with pytest.raises(NotAResultsFolder, match="no such folder"):
        load_results(tmp_path / "nowhere")


def test_folder_without_results_files_names_what_is_missing(tmp_path):
    (tmp_path / "points.csv").write_text("x\n")
    with pytest.raises(NotAResultsFolder) as e:
        load_results(tmp_path)
    message = str(e.value)
    assert str(tmp_path) in message and "not a results folder" in message
    assert "manifest.json" in message and "points.csv" not in message.split("(")[1]


def test_invalid_manifest_json(results_dir, tmp_path):
    folder = _copy(results_dir, tmp_path)
    (folder / "manifest.json").write_text("{ not json")
    with pytest.raises(InvalidInput, match=r"manifest.json: invalid JSON \(line 1"):
        load_results(folder)


def test_unsupported_schema_version(results_dir, tmp_path):
    folder = _copy(results_dir, tmp_path)
    manifest = json.loads((folder / "manifest.json").read_text())
    manifest["schema_version"] = 7
    (folder / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(InvalidInput, match="schema_version 7 is not supported"):
        load_results(folder)


def test_points_of_another_scenario_are_refused(results_dir, tmp_path):
    # A points.csv beside the manifest of another run (copied, or two runs into one folder):
    # refused, naming the point and the folder, not drawn as if it were this run's.
    folder = _copy(results_dir, tmp_path)
    manifest = json.loads((folder / "manifest.json").read_text())
    gone = manifest["scenario"]["points"][0]["id"]
    manifest["scenario"]["points"] = manifest["scenario"]["points"][1:]
    (folder / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(InvalidInput, match=rf"points.csv: line \d+: point '{gone}' is not one of "
                                           r"the \d+ points of the scenario in .*manifest.json"):
        load_results(folder)


def test_points_csv_without_the_fixed_columns(results_dir, tmp_path):
    folder = _copy(results_dir, tmp_path)
    (folder / "points.csv").write_text("point,rep,value\np1,0,1\n")
    with pytest.raises(InvalidInput, match="missing columns: backend, rt_workload"):
        load_results(folder)


def test_row_with_a_wrong_field_count(results_dir, tmp_path):
    folder = _copy(results_dir, tmp_path)
    _rewrite_points(folder, lambda lines: lines[3].pop())
    with pytest.raises(InvalidInput, match="line 4 has"):
        load_results(folder)


def test_non_numeric_cell_in_a_numeric_column(results_dir, tmp_path):
    folder = _copy(results_dir, tmp_path)

    def edit(lines):
        lines[2][lines[0].index("rt_slowdown")] = "fast"
    _rewrite_points(folder, edit)
    with pytest.raises(InvalidInput, match="line 3: column rt_slowdown: 'fast' is not a number"):
        load_results(folder)


def test_non_numeric_sample(results_dir, tmp_path):
    folder = _copy(results_dir, tmp_path)
    with (folder / "samples.csv").open("a") as f:
        f.write("p0,0,activation_delay,soon\n")
    with pytest.raises(InvalidInput, match="samples.csv: line .*: value_us 'soon'"):
        load_results(folder)

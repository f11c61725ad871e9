"""`plot`: files written (valid PNG + PDF per figure), printed summary, tables, exit codes."""

from __future__ import annotations

import csv
import io
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

import resultgen
from analysis import plot
from analysis.__main__ import main
from analysis.figures import REGISTRY
from checks import ROOT, assert_figure_files, run_cli
from test_figures import EXPECTED


def _read_csv(path):
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


@pytest.mark.parametrize("name", ["threshold", "sampling", "delay", "overhead", "grid",
                                  "regulation", "memguard"])
def test_plot_writes_every_supported_figure(results_dir, tmp_path, name):
    out = tmp_path / "figs"
    stream = io.StringIO()
    assert plot.run(results_dir(name), out, stream=stream) == 0
    printed = stream.getvalue()
    for stem in EXPECTED[name]:
        assert_figure_files(out, stem)
        assert f"{stem}.png, {stem}.pdf: " in printed
    figures = {p.stem for p in out.glob("*.png")}
    assert figures == EXPECTED[name]
    assert {p.stem for p in out.glob("*.pdf")} == figures
    kinds_drawn = {s.split("_threshold")[0] if s.startswith("rt_nrt_grid") else
                   "mechanisms" if s.startswith("mechanisms") else s for s in EXPECTED[name]}
    assert printed.count("  skipped ") == len(REGISTRY) - len(kinds_drawn)
    assert (out / "summary.csv").is_file()


def test_plot_summary_csv_holds_the_numbers_behind_the_figures(results_dir, loaded, tmp_path):
    plot.run(results_dir("threshold"), tmp_path, stream=io.StringIO())
    rows = _read_csv(tmp_path / "summary.csv")
    results = loaded("threshold")
    assert [r["point"] for r in rows] == [p.id for p in results.points]
    first = rows[0]
    values = [r["rt_slowdown"] for r in results.rows if r["point"] == first["point"]]
    assert float(first["rt_slowdown_mean"]) == pytest.approx(np.mean(values), abs=1e-6)
    assert float(first["rt_slowdown_min"]) == pytest.approx(min(values), abs=1e-6)
    assert float(first["rt_slowdown_max"]) == pytest.approx(max(values), abs=1e-6)
    assert first["reps"] == "3" and first["threshold_pct"] == "5"
    assert first["policy"] == "interval" and first["rt_workload"] == "bandwidth_read"


def test_plot_distributions_csv_pools_samples_per_sampling_mode_and_period(results_dir,
                                                                           loaded, tmp_path):
    plot.run(results_dir("delay"), tmp_path, stream=io.StringIO())
    rows = _read_csv(tmp_path / "distributions.csv")
    results = loaded("delay")
    row = next(r for r in rows if r["kind"] == "activation_delay" and r["sampling"] == "self"
               and r["sampling_period_us"] == "1000")
    values = np.concatenate([results.samples_of(p.id, "activation_delay")
                             for p in results.points if p.config["sampling"] == "self"
                             and p.config["sampling_period_us"] == 1000])
    assert int(row["samples"]) == values.size == 3 * 6
    assert float(row["median_us"]) == pytest.approx(np.median(values), abs=1e-6)
    assert float(row["max_us"]) == pytest.approx(values.max(), abs=1e-6)
    assert not [r for r in rows if r["kind"] == "queue_depth"]    # unknown kinds ignored


def test_plot_tables_hold_rt_response_times_and_baseline_spread(results_dir, loaded, tmp_path):
    plot.run(results_dir("threshold"), tmp_path, stream=io.StringIO())
    results = loaded("threshold")
    point = results.points[0]
    jobs = results.samples_of(point.id, "rt_job")
    assert jobs.size == point.reps * resultgen.RT_JOBS
    rows = _read_csv(tmp_path / "distributions.csv")
    assert [r for r in rows if r["kind"] == "rt_job"]
    summary = next(r for r in _read_csv(tmp_path / "summary.csv") if r["point"] == point.id)
    maxima = [r["rt_response_max_us"] for r in results.rows if r["point"] == point.id]
    assert float(summary["rt_response_max_us_max"]) == pytest.approx(max(maxima), abs=1e-6)
    assert "rt_isolation_cv_mean" in summary


def test_plot_defaults_to_a_figures_folder_inside_the_results(results_dir, tmp_path):
    folder = shutil.copytree(results_dir("regulation"), tmp_path / "run")
    assert plot.run(folder, stream=io.StringIO()) == 0
    assert_figure_files(folder / "figures", "slowdown_vs_regulation_period")


def test_plot_without_any_supported_figure_still_writes_the_summary(tmp_path):
    # One workload alone: no sweep, no co-run, too few workloads for the Table 1 figure.
    folder = resultgen.write_results(tmp_path / "one", resultgen.rt_alone_points()[:1])
    out = tmp_path / "out"
    stream = io.StringIO()
    assert plot.run(folder, out, stream=stream) == 0
    assert "no figure applies" in stream.getvalue()
    assert not list(out.glob("*.png"))
    assert len(_read_csv(out / "summary.csv")) == 1


def test_plot_prints_what_the_figures_show(results_dir, loaded, tmp_path):
    stream = io.StringIO()
    assert plot.run(results_dir("threshold"), tmp_path, stream=stream) == 0
    text = stream.getvalue()
    table = text[text.index("what the figures show"):text.index("unregulated co-run (")]
    table = table.splitlines()
    assert table[1].split("  ") and [c.strip() for c in table[1].split("  ") if c.strip()] == [
        "RT workload", "nRT workload", "policy", "threshold (%)", "RT slowdown", "nRT slowdown"]
    first = loaded("threshold").points[0]
    row = table[2].split()
    assert row[-2:] == [f"{first.mean('rt_slowdown'):.3f}", f"{first.mean('nrt_slowdown'):.3f}"]
    assert len(table) - 2 == min(len(loaded("threshold").points), plot.DIGEST_ROWS) + (
        1 if len(loaded("threshold").points) > plot.DIGEST_ROWS else 0)


def test_cli_plot_as_rosguard_runs_it(results_dir, tmp_path):
    done = run_cli("plot", results_dir("overhead"), "--out", tmp_path)
    assert done.returncode == 0, done.stderr
    assert "sampling_overhead_vs_sampling_period.png" in done.stdout
    assert "skipped RT x nRT grid:" in done.stdout
    assert done.stderr == ""


def test_cli_not_a_results_folder_is_exit_2_with_one_line(tmp_path):
    done = run_cli("plot", tmp_path)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr
    assert done.stderr.startswith("error: ") and str(tmp_path) in done.stderr
    assert "not a results folder (missing manifest.json, points.csv)" in done.stderr


def test_plot_of_a_folder_without_rows_is_invalid_input(results_dir, tmp_path, capsys):
    folder = shutil.copytree(results_dir("threshold"), tmp_path / "empty")
    header = (folder / "points.csv").read_text().splitlines()[0]
    (folder / "points.csv").write_text(header + "\n")
    assert main(["plot", str(folder)]) == 2
    assert "holds no rows yet" in capsys.readouterr().err


def test_unwritable_output_is_a_runtime_failure(results_dir, tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    assert main(["plot", str(results_dir("regulation")), "--out", str(blocker)]) == 1
    assert capsys.readouterr().err.startswith("error: ")


def test_usage_errors_and_help(capsys):
    assert main([]) == 2
    with pytest.raises(SystemExit) as e:
        main(["plot"])
    assert e.value.code == 2
    with pytest.raises(SystemExit) as e:
        main(["--help"])
    assert e.value.code == 0
    out = capsys.readouterr().out
    assert "plot" in out and "compare" in out and "exit codes" in out


ROSGUARD = os.environ.get("ROSGUARD_BIN")


@pytest.mark.skipif(not ROSGUARD, reason="ROSGUARD_BIN not set (ctest sets it after a build)")
def test_rosguard_plot_end_to_end(results_dir, tmp_path):
    done = run_cli("plot", results_dir("threshold"), "--out", tmp_path, command=[ROSGUARD])
    assert done.returncode == 0, done.stderr
    assert_figure_files(tmp_path, "slowdown_vs_threshold")
    done = run_cli("compare", results_dir("threshold"), tmp_path / "none", command=[ROSGUARD])
    assert done.returncode == 2 and "no such folder" in done.stderr


def test_missing_module_is_one_line_naming_the_interpreter(results_dir, tmp_path):
    # A pandas that cannot be imported, ahead of the real one on the path: as on a Python
    # without python3-pandas.
    shadow = tmp_path / "shadow"
    (shadow / "pandas").mkdir(parents=True)
    (shadow / "pandas" / "__init__.py").write_text("raise ImportError('no pandas here')\n")
    env = dict(os.environ, PYTHONPATH=f"{shadow}:{ROOT}", MPLBACKEND="Agg",
               PYTHONDONTWRITEBYTECODE="1")
    commands = [[sys.executable, "-m", "analysis"]]
    if ROSGUARD:
        env["ROSGUARD_PYTHON"] = sys.executable
        commands.append([ROSGUARD])
    for command in commands:
        for args in (["plot", results_dir("threshold"), "--out", tmp_path / "figs"],
                     ["compare", results_dir("threshold"), results_dir("threshold")]):
            done = subprocess.run(command + [str(a) for a in args], env=env, capture_output=True,
                                  text=True, timeout=300, check=False)
            assert done.returncode == 1, (command, args, done.stderr)
            lines = done.stderr.splitlines()
            assert len(lines) == 1, done.stderr
            assert lines[0].startswith(f"error: {sys.executable} cannot import pandas ")
            assert "python3-pandas" in lines[0] and "ROSGUARD_PYTHON" in lines[0]
    assert not (tmp_path / "figs").exists()

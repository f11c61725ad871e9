"""The command line as rosguard calls it: python3 -m analysis ..., exit codes, messages."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

import resultgen

ROOT = Path(__file__).resolve().parents[2]
ROSGUARD = os.environ.get("ROSGUARD_BIN")


def analysis(*args):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    return subprocess.run([sys.executable, "-m", "analysis", *map(str, args)], env=env,
                          capture_output=True, text=True, timeout=300)


def test_help_lists_both_commands():
    r = analysis("--help")
    assert r.returncode == 0
    assert "plot" in r.stdout and "compare" in r.stdout


def test_no_command_is_a_usage_error():
    assert analysis().returncode == 2


def test_a_folder_that_is_not_a_results_folder_exits_2_with_one_line(tmp_path):
    r = analysis("plot", tmp_path / "missing")
    assert r.returncode == 2
    assert r.stderr.startswith("error: ")
    assert "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_plot_defaults_to_a_figures_folder_inside_the_results(make_results):
    folder = make_results("t", resultgen.threshold_points(), reps=1)
    r = analysis("plot", folder)
    assert r.returncode == 0, r.stderr
    assert (folder / "figures" / "slowdown_vs_threshold.png").is_file()


def test_compare_defaults_to_a_compare_folder_inside_b(make_results):
    a = make_results("a", resultgen.threshold_points(), reps=1, backend="hw")
    b = make_results("b", resultgen.threshold_points(), reps=1, backend="sim", seed=2)
    r = analysis("compare", a, b)
    assert r.returncode == 0, r.stderr
    assert (b / "compare" / "summary.json").is_file()
    assert "MAPE" in r.stdout


@pytest.mark.skipif(not ROSGUARD, reason="ROSGUARD_BIN not set (ctest sets it)")
def test_rosguard_plot_and_compare_run_this_package(make_results, tmp_path):
    folder = make_results("t", resultgen.grid_points(), reps=1)
    r = subprocess.run([ROSGUARD, "plot", str(folder), "--out", str(tmp_path / "f")],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "f" / "rt_nrt_grid_threshold20.png").is_file()
    r = subprocess.run([ROSGUARD, "compare", str(folder), str(tmp_path / "none")],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 2
    assert "not a results folder" in r.stderr or "no such folder" in r.stderr

"""`calibration DIR`: the measured-vs-fitted figures of a `rosguard calibrate` folder, on
measurements taken on the development VM (tests/sim/fixtures/calibration-vm.json)."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

from analysis import calibration
from checks import assert_figure_files, run_cli

ROOT = Path(__file__).resolve().parents[2]
FIXTURE = ROOT / "tests" / "sim" / "fixtures" / "calibration-vm.json"


def calibration_folder(tmp_path: Path, fit: bool) -> Path:
    """A calibrate output folder: the fixture's measurements and, with `fit`, a fit that
    predicts every run 5 % slower than measured and a platform with one fitted cost."""
    doc = json.loads(FIXTURE.read_text())
    if fit:
        doc["fit"] = {"runs": [{"index": i, "used": True, "measured_ns": r["ns_per_line"],
                                "predicted_ns": 1.05 * r["ns_per_line"]}
                               for i, r in enumerate(doc["measurements"]["runs"])]}
        (tmp_path / "platform.json").write_text(json.dumps(
            {"costs": {"publish_us": {"dist": "lognormal", "median_us": 7.5, "sigma": 0.1}}}))
    (tmp_path / "calibration.json").write_text(json.dumps(doc))
    return tmp_path


def test_predictions_are_read_by_run_index(tmp_path):
    doc = json.loads((calibration_folder(tmp_path, fit=True) / "calibration.json").read_text())
    pred = calibration.predictions(doc)
    runs = doc["measurements"]["runs"]
    assert len(pred) == len(runs)
    assert abs(pred[3] - 1.05 * runs[3]["ns_per_line"]) < 1e-12


def test_every_figure_is_drawn_with_and_without_a_fit(tmp_path):
    for fit in (True, False):
        (tmp_path / str(fit)).mkdir()
        folder = calibration_folder(tmp_path / str(fit), fit)
        result = run_cli("calibration", folder)
        assert result.returncode == 0, result.stderr
        for stem in ("calibration_isolation", "calibration_corun", "calibration_costs"):
            assert_figure_files(folder / "figures", stem)


def test_corun_slowdowns_are_measured_over_the_same_kernel_alone(tmp_path):
    doc = json.loads((calibration_folder(tmp_path, fit=True) / "calibration.json").read_text())
    runs = doc["measurements"]["runs"]
    alone = {(r["kernel"], r["working_set_kb"]): r["ns_per_line"]
             for r in runs if not r["corunners"]}
    corun = next(r for r in runs if r["corunners"])
    expected = corun["ns_per_line"] / alone[(corun["kernel"], corun["working_set_kb"])]
    fig = calibration.draw_corun(doc)
    bars = [p.get_width() for p in fig.axes[0].patches]
    assert abs(bars[0] - expected) < 1e-9
    # The fitted bar: both predictions are 5 % above measured, so the ratio is the measured one.
    n = len(bars) // 2
    assert abs(bars[n] - expected) < 1e-9


def test_a_folder_without_calibration_json_is_invalid_input(tmp_path):
    result = run_cli("calibration", tmp_path)
    assert result.returncode == 2
    assert "not a calibration folder" in result.stderr


# The co-runner curves (issue 24): measured on the 16-core Xeon VM (../shared/measured/
# xeon16-2026-11-26, `rosguard calibrate --quick`, co-runners 1 to 15; its fit was refused).
XEON16 = ROOT / "tests" / "sim" / "fixtures" / "measured" / "xeon16-2026-11-26-quick.json"


def xeon16(tmp_path: Path, fit: bool) -> Path:
    """A calibrate folder of the Xeon's measurements; with `fit`, a fit that predicts each run
    k % slower than measured (k: its co-runners), so the error per k is k %."""
    doc = json.loads(XEON16.read_text())
    if fit:
        doc["fit"] = {"runs": [{"index": i, "used": True, "measured_ns": r["ns_per_line"],
                                "predicted_ns": (1 + 0.01 * len(r["corunners"]))
                                * r["ns_per_line"]}
                               for i, r in enumerate(doc["measurements"]["runs"])]}
    tmp_path.mkdir(parents=True, exist_ok=True)
    (tmp_path / "calibration.json").write_text(json.dumps(doc))
    return tmp_path


def test_corunner_curves_give_the_error_per_k(tmp_path):
    doc = json.loads((xeon16(tmp_path, fit=True) / "calibration.json").read_text())
    rows = calibration.curves(doc)
    dram_read = ("bandwidth_read", 262144.0)
    latency = [r for r in rows if (r["corunner"], r["corunner_kb"]) == dram_read
               and r["kernel"] == "latency" and r["working_set_kb"] == 262144.0]
    # The curve: alone, then 1, 2, 4, 8, 15 co-runners (the suite's counts on 16 CPUs).
    assert [r["k"] for r in latency] == [0, 1, 2, 4, 8, 15]
    assert [r["error_pct"] for r in latency] == pytest.approx([0, 1, 2, 4, 8, 15])
    runs = doc["measurements"]["runs"]
    alone = next(r for r in runs if r["kernel"] == "latency" and r["working_set_kb"] == 262144.0
                 and not r["corunners"])
    assert latency[0]["measured_ns"] == alone["ns_per_line"]


def test_the_mess_curve_is_latency_against_the_corunners_bandwidth(tmp_path):
    doc = json.loads((xeon16(tmp_path, fit=False) / "calibration.json").read_text())
    rows = calibration.curves(doc)
    mess = calibration.mess_points(rows, ("bandwidth_read", 262144.0))
    assert [m[0] for m in mess] == [1, 2, 4, 8, 15]
    runs = doc["measurements"]["runs"]

    def run(kernel, k):
        return next(r for r in runs if r["kernel"] == kernel and r["working_set_kb"] == 262144.0
                    and len(r["corunners"]) == k
                    and {c["kernel"] for c in r["corunners"]} == {"bandwidth_read"}
                    and {c["working_set_kb"] for c in r["corunners"]} == {262144.0})
    k, bandwidth, latency, fitted_bw, fitted_ns = mess[2]
    # 4 x one bandwidth_read's MiB/s with 4 co-runners of its kind; 64 B per line.
    assert bandwidth == pytest.approx(4 * 64 / run("bandwidth_read", 4)["ns_per_line"] * 1e9
                                      / 2**20)
    assert latency == run("latency", 4)["ns_per_line"]
    assert math.isnan(fitted_bw) and math.isnan(fitted_ns)     # no fit


def test_the_curves_figure_and_csv_are_written(tmp_path):
    for fit in (True, False):
        folder = xeon16(tmp_path / str(fit), fit)
        result = run_cli("calibration", folder)
        assert result.returncode == 0, result.stderr
        assert_figure_files(folder / "figures", "calibration_curves")
        with (folder / "figures" / "calibration_curves.csv").open() as f:
            rows = list(csv.DictReader(f))
        row = next(r for r in rows if r["corunner"] == "bandwidth_write" and r["k"] == "8"
                   and r["kernel"] == "latency" and r["working_set_kb"] == "8192")
        assert (float(row["error_pct"]) == pytest.approx(8.0)) if fit else row["error_pct"] == ""


def test_two_cores_give_curves_of_one_corunner_and_no_corun_no_curve(tmp_path):
    # The 2-vCPU VM's calibration: alone and with one co-runner.
    doc = json.loads(calibration_folder(tmp_path, fit=True).joinpath("calibration.json")
                     .read_text())
    assert {r["k"] for r in calibration.curves(doc)} == {0, 1}
    doc["measurements"]["runs"] = [r for r in doc["measurements"]["runs"] if not r["corunners"]]
    with pytest.raises(calibration.InvalidInput, match="no co-runner curve"):
        calibration.draw_curves(doc)

"""`calibration DIR`: the measured-vs-fitted figures of a `rosguard calibrate` folder, on
measurements taken on the development VM (tests/sim/fixtures/calibration-vm.json)."""

from __future__ import annotations

import json
from pathlib import Path

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

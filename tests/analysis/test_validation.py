"""`validate HW SIM --out DIR` and `validate-table`: hand-computed errors and goal marks,
the report files and figure, failed scenarios, the README block."""

from __future__ import annotations

import csv
import json
import math

import pytest

import resultgen
from analysis import validation
from checks import assert_figure_files, run_cli

# scenario -> point -> [(rt_slowdown, nrt_slowdown) per repetition]; hw measured, sim predicted.
HW = {
    "alpha": {"p0000000001": [(1.0, 2.0), (1.2, 2.0)],     # means 1.1, 2.0
              "p0000000002": [(1.02, 3.0)],
              "p0000000003": [(1.5, 1.04)]},                # only in hw
    "beta": {"p0000000004": [(1.25, 5.0)]},
}
SIM = {
    "alpha": {"p0000000001": [(1.188, 2.2)],
              "p0000000002": [(1.02, 2.4), (1.02, 2.4)]},
    "beta": {"p0000000004": [(1.30, 5.5)]},
}


def write_folder(folder, points, backend, isolation=None):
    """A results folder with only the cells validate needs (as in test_compare); ``isolation``
    (rt_us, nrt_us) fills every row's isolation times."""
    folder.mkdir(parents=True)
    header = resultgen.FIXED_COLUMNS + resultgen.EXTRA_COLUMNS
    with (folder / "points.csv").open("w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(header)
        for index, (pid, reps) in enumerate(points.items()):
            for rep, (rt, nrt) in enumerate(reps):
                cells = {"point": pid, "rep": rep, "backend": backend,
                         "rt_workload": "bandwidth_read", "nrt_workload": "bandwidth_read",
                         "policy": "interval", "sampling": "self", "scope": "core",
                         "threshold_pct": 10 * (index + 1), "sampling_period_us": 250,
                         "regulation_period_us": 5000, "rt_slowdown": rt, "nrt_slowdown": nrt,
                         "platform": "vm-2core"}
                if isolation:
                    cells["rt_isolation_us"], cells["nrt_isolation_us"] = isolation
                w.writerow([cells.get(c, "") for c in header])
    (folder / "manifest.json").write_text(json.dumps({
        "schema_version": 1, "backend": backend, "status": "complete",
        "start_time": f"2026-01-01T00:0{len(points)}:00Z",
        "end_time": f"2026-01-01T00:1{len(points)}:00Z",
        "tool": {"name": "rosguard", "version": "0.1.0", "git_revision": "abc123"},
        "host": {"hostname": "testhost", "cpu_model": "Test CPU", "cpus_online": 2},
        "scenario": {"given": {"description": f"checks {folder.name}"}}}))
    return folder


@pytest.fixture
def suite(tmp_path):
    for root, values, backend in (("hw", HW, "hw"), ("sim", SIM, "sim")):
        for name, points in values.items():
            write_folder(tmp_path / root / name, points, backend)
    return tmp_path / "hw", tmp_path / "sim"


def test_hand_computed_errors(suite):
    report, pairs = validation.build_report(*suite)
    assert [s["name"] for s in report["scenarios"]] == ["alpha", "beta"]
    alpha = report["scenarios"][0]
    assert alpha["common_points"] == 2 and alpha["only_hw"] == ["p0000000003"]
    assert alpha["description"] == "checks alpha"
    # RT alpha: |1.188 - 1.1| / 1.1 = 8 %, 0 % -> MAPE 4 %; excess: only hw 1.1 >= 1.05,
    # |0.188 - 0.1| / 0.1 = 88 %.
    assert alpha["rt"]["mape_pct"] == pytest.approx(4.0)
    assert alpha["rt"]["excess_pairs"] == 1
    assert alpha["rt"]["excess_error_pct"] == pytest.approx(88.0)
    # nRT alpha: 10 %, 20 % -> 15 %; excess |1.2 - 1| / 1 = 20 %, |1.4 - 2| / 2 = 30 % -> 25 %.
    assert alpha["nrt"]["mape_pct"] == pytest.approx(15.0)
    assert alpha["nrt"]["excess_error_pct"] == pytest.approx(25.0)
    assert alpha["nrt"]["excess_error_max_pct"] == pytest.approx(30.0)
    # hw spread: RT point 1 (1.2 - 1.0) / 1.1; point 2 has one repetition (not counted).
    assert alpha["rt"]["hw_spread_pct"] == pytest.approx(100 * 0.2 / 1.1)
    assert alpha["goals"]["rt_mape"]["status"] == "met"
    assert alpha["goals"]["nrt_mape"]["status"] == "missed"
    assert alpha["goals"]["rt_excess"]["status"] == "missed"
    # Overall: every point pooled. RT: 8, 0, 4 % -> 4 %; nRT: 10, 20, 10 % -> 40/3.
    overall = report["overall"]
    assert overall["rt"]["pairs"] == 3 and overall["nrt"]["pairs"] == 3
    assert overall["rt"]["mape_pct"] == pytest.approx(4.0)
    assert overall["nrt"]["mape_pct"] == pytest.approx(40.0 / 3)
    # RT excess: 88 % (alpha), |0.30 - 0.25| / 0.25 = 20 % (beta).
    assert overall["rt"]["excess_error_pct"] == pytest.approx(54.0)
    assert overall["nrt"]["excess_error_pct"] == pytest.approx((20 + 30 + 12.5) / 3)
    assert overall["goals"]["nrt_excess"]["status"] == "missed"
    # Resolved: RT none (alpha's 1.0 / 1.2 over two repetitions: t 12.7; the others have one);
    # nRT alpha's 2.0 / 2.0 (no spread), its excess error 20 %.
    assert overall["rt"]["excess_resolved_pairs"] == 0
    assert overall["nrt"]["excess_resolved_pairs"] == 1
    assert overall["nrt"]["excess_error_resolved_pct"] == pytest.approx(20.0)
    assert [p["excess_resolved"] for p in report["points"]].count(True) == 1
    assert ("RT n/a (0 of 2 points), nRT 20.0 % (1 of 3 points)"
            in validation.markdown(report))
    assert len(pairs) == 6
    assert report["measured_from"] == "2026-01-01T00:01:00Z"       # beta (1 point) first
    assert report["measured_to"] == "2026-01-01T00:13:00Z"


def test_excess_only_where_measured_excess_is_large():
    stat = validation.Stat.of
    small = validation.Pair("s", "p", "rt", stat([1.04]), stat([1.5]))
    assert math.isnan(small.excess_error_pct)
    assert small.error_pct == pytest.approx(100 * 0.46 / 1.04)
    edge = validation.Pair("s", "p", "rt", stat([1.05]), stat([1.0]))
    assert edge.excess_error_pct == pytest.approx(-100.0)
    errors = validation.node_errors([small])
    assert errors["excess_pairs"] == 0 and math.isnan(errors["excess_error_pct"])


def test_excess_resolved_by_the_confidence_interval():
    stat = validation.Stat.of
    # 1.09..1.11 over 5: the 95 % CI of the mean (t 2.776, std 0.00707) is 1.0912..1.1088.
    tight = validation.Pair("s", "p1", "rt", stat([1.09, 1.10, 1.11, 1.10, 1.10]), stat([1.08]))
    noisy = validation.Pair("s", "p2", "rt", stat([0.90, 1.40, 1.00, 1.20, 1.00]), stat([1.0]))
    once = validation.Pair("s", "p3", "rt", stat([1.5]), stat([1.0]))   # one repetition
    assert [p.excess_resolved for p in (tight, noisy, once)] == [True, False, False]
    # At the bound: the lower end 1 + 0.05 - / + 0.0001 (half-width 2.776 x std / sqrt(5)).
    edge = [validation.Pair("s", "p", "rt", validation.Stat(5, 1.07, 1.0, 1.1, std), stat([1.0]))
            for std in (0.0160, 0.0162)]
    assert [p.excess_resolved for p in edge] == [True, False]
    errors = {"rt": validation.node_errors([tight, noisy, once]),
              "nrt": validation.node_errors([noisy])}
    assert errors["rt"]["excess_pairs"] == 3
    assert errors["rt"]["excess_resolved_pairs"] == 1
    assert errors["rt"]["excess_error_resolved_pct"] == pytest.approx(20.0)  # (0.08-0.10)/0.10
    assert errors["rt"]["excess_error_pct"] == pytest.approx((20.0 + 100.0 + 100.0) / 3)
    assert math.isnan(errors["nrt"]["excess_error_resolved_pct"])
    text = validation.resolved_summary(errors)
    assert "RT 20.0 % (1 of 3 points)" in text and "nRT n/a (0 of 1 points)" in text


def test_isolation_offset_by_hand(tmp_path):
    # hw isolation 40 / 50 ms, the model 44 / 40: RT +10 %, nRT -20 %, in every point.
    points = {"p0000000001": [(1.0, 2.0)], "p0000000002": [(1.1, 3.0)]}
    write_folder(tmp_path / "hw" / "alpha", points, "hw", (40000.0, 50000.0))
    write_folder(tmp_path / "sim" / "alpha", points, "sim", (44000.0, 40000.0))
    report, pairs = validation.build_report(tmp_path / "hw", tmp_path / "sim")
    assert [round(p.isolation_offset_pct, 6) for p in pairs] == [10.0, -20.0] * 2
    for errors in (report["scenarios"][0], report["overall"]):
        assert errors["rt"]["isolation_offset_pct"] == pytest.approx(10.0)
        assert errors["nrt"]["isolation_offset_pct"] == pytest.approx(-20.0)
    assert report["points"][1]["isolation_offset_pct"] == pytest.approx(-20.0)
    text = validation.markdown(report)
    assert "| +10.0 % / -20.0 % |" in text          # the summary table's column
    # Without isolation times (the suite fixture) the offset is not known, and says so.
    stat = validation.Stat.of
    bare = validation.Pair("s", "p", "nrt", stat([2.0]), stat([2.0]))
    assert math.isnan(bare.isolation_offset_pct)
    assert math.isnan(validation.node_errors([bare])["isolation_offset_pct"])


@pytest.mark.parametrize("value, status", [(4.99, "met"), (5.0, "met"), (5.01, "missed"),
                                           (math.nan, "n/a")])
def test_goal_marks(value, status):
    errors = {"rt": {"mape_pct": value, "excess_error_pct": math.nan},
              "nrt": {"mape_pct": 1.0, "excess_error_pct": 25.0}}
    marks = validation.goal_marks(errors)
    assert marks["rt_mape"]["status"] == status
    assert marks["nrt_mape"]["status"] == "met"
    assert marks["rt_excess"]["status"] == "n/a"
    assert marks["nrt_excess"]["status"] == "missed"


def test_missing_and_failed_scenarios_are_listed(suite):
    hw, sim = suite
    report, _ = validation.build_report(hw, sim, ["alpha", "gamma"],
                                        [{"scenario": "delta", "reason": "hw run failed"}])
    assert [s["name"] for s in report["scenarios"]] == ["alpha"]
    failed = {f["scenario"]: f["reason"] for f in report["failed"]}
    assert failed["delta"] == "hw run failed"
    assert "gamma" in failed["gamma"] and "no such folder" in failed["gamma"]


def test_run_writes_report_and_figure(suite, tmp_path):
    out = tmp_path / "out"
    done = run_cli("validate", *suite, "--out", out, "--note", "load 1.5",
                   "--failed", "delta=the hw run failed")
    assert done.returncode == 0, done.stderr
    assert "1 of 4 goals met over the suite; missed: nRT-slowdown MAPE" in done.stdout
    report = json.loads((out / "report.json").read_text())
    assert report["overall"]["rt"]["excess_error_pct"] == pytest.approx(54.0)
    assert report["notes"] == ["load 1.5"]
    assert report["failed"] == [{"scenario": "delta", "reason": "the hw run failed"}]
    assert report["figure"] == ["validation_scatter.png", "validation_scatter.pdf"]
    md = (out / "report.md").read_text()
    assert "| alpha | 2 | 4.0 % met | 15.0 % **missed** |" in md
    assert "| **all** | 3 |" in md
    assert "testhost" in md and "0.1.0 abc123" in md and "load 1.5" in md
    assert "**delta**: the hw run failed" in md
    assert_figure_files(out, "validation_scatter")


def test_nan_survives_the_json_round_trip(suite, tmp_path):
    out = tmp_path / "out"
    assert run_cli("validate", *suite, "--out", out).returncode == 0
    report = validation.load_report(out / "report.json")
    assert report["scenarios"][1]["rt"]["hw_spread_pct"] != report["scenarios"][1]["rt"][
        "hw_spread_pct"]                                           # NaN: one repetition
    assert "n/a" in "\n".join(validation.summary_table(report))


def test_readme_block(suite, tmp_path):
    out = tmp_path / "out"
    assert run_cli("validate", *suite, "--out", out).returncode == 0
    shown = run_cli("validate-table", out / "report.json")
    assert shown.returncode == 0, shown.stderr
    assert shown.stdout.startswith("![sim vs hw validation](validation_scatter.png)")
    readme = tmp_path / "README.md"
    readme.write_text("intro\n<!-- validation:begin -->\nold\n<!-- validation:end -->\nend\n")
    done = run_cli("validate-table", out / "report.json", "--readme", readme,
                   "--figure-dir", tmp_path / "docs" / "figures")
    assert done.returncode == 0, done.stderr
    text = readme.read_text()
    assert "old" not in text and text.startswith("intro\n<!-- validation:begin -->\n")
    assert "](docs/figures/validation_scatter.png)" in text
    assert "| alpha | 2 |" in text and text.endswith("<!-- validation:end -->\nend\n")
    assert_figure_files(tmp_path / "docs" / "figures", "validation_scatter")


def test_readme_without_markers_and_bad_report_are_input_errors(suite, tmp_path):
    out = tmp_path / "out"
    assert run_cli("validate", *suite, "--out", out).returncode == 0
    readme = tmp_path / "README.md"
    readme.write_text("no markers\n")
    figures = tmp_path / "figures"
    done = run_cli("validate-table", out / "report.json", "--readme", readme,
                   "--figure-dir", figures)
    assert done.returncode == 2 and "validation:begin" in done.stderr
    assert not figures.exists() and readme.read_text() == "no markers\n"
    (tmp_path / "other.json").write_text('{"a": 1}')
    done = run_cli("validate-table", tmp_path / "other.json")
    assert done.returncode == 2 and "not a validation report" in done.stderr
    done = run_cli("validate", tmp_path / "missing", tmp_path / "missing2", "--out", out)
    assert done.returncode == 2 and "no such folder" in done.stderr


def test_figure_limits_ignore_disturbed_points_and_say_so():
    from analysis.figures import validation as figure
    stat = validation.Stat.of
    calm = [validation.Pair("a", f"p{i}", "rt", stat([1.0 + i / 100, 1.01 + i / 100]),
                            stat([1.02 + i / 100])) for i in range(5)]
    wild = validation.Pair("b", "px", "rt", stat([1.0, 108.0]), stat([1.05]))
    assert figure.disturbed(wild) and not any(figure.disturbed(p) for p in calm)
    fig = figure.draw(calm + [wild], ["a", "b"], {}, validation.EXCESS_MIN, "note")
    rt_panel = fig.axes[0]
    assert rt_panel.get_xlim()[1] < 1.2            # the 54.5 mean is left outside
    texts = [t.get_text() for t in rt_panel.texts]
    assert any("1 point(s) with disturbed hw repetitions" in t for t in texts), texts
    assert rt_panel.get_xscale() == "linear"


def test_a_value_just_over_its_bound_does_not_print_as_the_bound():
    errors = {"rt": {"mape_pct": 5.033, "excess_error_pct": math.nan, "excess_pairs": 0},
              "nrt": {"mape_pct": 9.2, "excess_error_pct": 20.01, "excess_pairs": 3}}
    goals = validation.goal_marks(errors)
    assert validation._cell(errors, goals, "rt", "mape_pct") == "5.03 % **missed**"
    assert validation._cell(errors, goals, "nrt", "mape_pct") == "9.2 % met"
    assert validation._cell(errors, goals, "nrt", "excess_error_pct") == \
        "20.01 % (n=3) **missed**"


# Data the report step met on real machines (issue 22): a mean just outside min..max (the
# rounding of a mean over equal repetitions: a deterministic sim repeats its value exactly),
# NaN, one repetition, a scenario without points. The figure must be drawn, not crash.
EQUAL_REPS = [1.009] * 7                   # np.mean: 1.0090000000000001 > max


def test_error_bars_are_non_negative_distances():
    from analysis.figures import validation as figure
    assert float(validation.np.mean(EQUAL_REPS)) > max(EQUAL_REPS)   # the case is real
    stat = validation.Stat.of(EQUAL_REPS)
    assert figure.bar_lengths(stat.mean, stat.min, stat.max) == (stat.mean - stat.min, 0.0)
    assert figure.bar_lengths(1.0, 1.2, 0.8) == (0.0, 0.0)          # spread beside the centre
    assert figure.bar_lengths(1.0, math.nan, 1.5) == (0.0, 0.5)
    assert figure.bar_lengths(1.0, 0.5, math.inf) == (0.5, 0.0)
    below, above = figure.bar_lengths(math.nan, 0.5, 1.5)
    assert below == 0.0 and above == 0.0


def test_figure_is_drawn_from_awkward_pairs(tmp_path):
    from analysis import style
    from analysis.figures import validation as figure
    Stat = validation.Stat
    equal = Stat.of(EQUAL_REPS)
    pairs = [
        validation.Pair("a", "p1", "nrt", Stat.of([2.0, 2.5, 3.0]), equal),
        validation.Pair("a", "p2", "nrt", Stat(3, 2.0, 2.1, 1.9, 0.1), Stat(3, 2.2, 2.3, 2.25, 0)),
        validation.Pair("a", "p3", "rt", Stat(2, math.nan, 1.0, 1.1, 0.0), Stat.of([1.05])),
        validation.Pair("a", "p4", "rt", Stat(2, 1.1, math.nan, math.nan, math.nan),
                        Stat(1, 1.1, math.nan, 1.2, 0.0)),
        validation.Pair("b", "p5", "rt", Stat.of([1.2]), Stat.of([1.2])),
        # Measured excess 0.2, simulated excess 0.001: below the excess panel's bar floor.
        validation.Pair("b", "p6", "nrt", Stat.of([1.2, 1.2]), Stat.of([1.001, 1.001])),
    ]
    fig = figure.draw(pairs, ["a", "b", "empty"], {}, validation.EXCESS_MIN, "note")
    style.save(fig, tmp_path, "awkward")
    assert_figure_files(tmp_path, "awkward")
    fig = figure.draw([], ["empty"], {}, validation.EXCESS_MIN, "note")      # nothing at all
    style.save(fig, tmp_path, "nothing")
    assert_figure_files(tmp_path, "nothing")


def test_run_writes_the_figure_from_awkward_results(tmp_path):
    # p2: the sim's nRT excess (0.0025) is below the excess panel's bar floor (excess_min / 10)
    # while the measured one is 0.55: the data that crashed `make validate` on 2026-11-26 (a
    # model of another machine predicting no nRT slowdown); p3: one repetition, the sim's nRT
    # cell empty; "empty": a scenario without points.
    hw = {"awkward": {"p0000000001": [(1.009, 1.009)] * 7,
                      "p0000000002": [(1.2, 1.5), (1.25, 1.6)],
                      "p0000000003": [(1.1, 2.0)]},
          "empty": {}}
    sim = {"awkward": {"p0000000001": [(1.009, 1.009)] * 7,
                       "p0000000002": [(1.21, 1.002), (1.22, 1.003)],
                       "p0000000003": [(1.1, "")]},
           "empty": {}}
    for root, values, backend in (("hw", hw, "hw"), ("sim", sim, "sim")):
        for name, points in values.items():
            write_folder(tmp_path / root / name, points, backend)
    out = tmp_path / "out"
    done = run_cli("validate", tmp_path / "hw", tmp_path / "sim", "--out", out)
    assert done.returncode == 0, done.stderr
    assert_figure_files(out, "validation_scatter")
    report = json.loads((out / "report.json").read_text())
    assert "awkward" in [s["name"] for s in report["scenarios"]]
    assert "empty" in [s["name"] for s in report["scenarios"]] + \
        [f["scenario"] for f in report["failed"]]


def test_readme_block_names_the_day_and_the_cpu(suite, tmp_path):
    out = tmp_path / "out"
    done = run_cli("validate", *suite, "--out", out, "--cpu", "AMD EPYC 7B13")
    assert done.returncode == 0, done.stderr
    report = validation.load_report(out / "report.json")
    assert report["cpu"] == "AMD EPYC 7B13"
    block = validation.readme_section(report, "f.png")
    # The earliest start of the hw runs (write_folder: 2026-01-01T00:0<points>:00Z).
    assert "**Validated on 2026-01-01 on AMD EPYC 7B13 (2 CPUs).**" in block
    assert "Validated on 2026-01-01 on AMD EPYC 7B13" in (out / "report.md").read_text()
    # Without --cpu: the manifest's cpu_model.
    report, _ = validation.build_report(*suite)
    assert validation.headline(report) == "Validated on 2026-01-01 on Test CPU (2 CPUs)"


def test_a_sim_model_of_another_machine_is_said(suite, tmp_path):
    hw, sim = suite
    for folder in (sim / "alpha", sim / "beta"):
        manifest = json.loads((folder / "manifest.json").read_text())
        manifest["host_platform"] = {"sim": {"machine": {
            "measured_on": {"cpu_model": "AMD EPYC"}, "matches": False,
            "differences": ["CPU model 'AMD EPYC' (model) vs 'Test CPU' (this machine)"]}}}
        (folder / "manifest.json").write_text(json.dumps(manifest))
    out = tmp_path / "out"
    done = run_cli("validate", hw, sim, "--out", out)
    assert done.returncode == 0, done.stderr
    assert "warning: the sim's host model was measured on another machine" in done.stdout
    report = validation.load_report(out / "report.json")
    assert "CPU model 'AMD EPYC' (model) vs 'Test CPU'" in validation.readme_section(report, "f")
    assert validation._model_line({"sim_model_machine": None}) == ""      # no host model
    assert validation._model_line({"sim_model_machine": {"matches": True}}) == ""
    assert "does not record" in validation._model_line(
        {"sim_model_machine": {"measured_on": None, "matches": None}})


# The prediction band: the sim runs on two band platforms of the model (make validate:
# BAND_ROOT/<variant>/<scenario>/). The "high" run of alpha lacks p0000000002.
BAND = {
    "m-x-low": {"alpha": {"p0000000001": [(1.15, 1.9)], "p0000000002": [(1.0, 2.2)]},
                "beta": {"p0000000004": [(1.2, 4.8)]}},
    "m-x-high": {"alpha": {"p0000000001": [(1.25, 2.5)]},
                 "beta": {"p0000000004": [(1.35, 5.2)]}},
}


@pytest.fixture
def band_root(suite, tmp_path):
    for variant, scenarios in BAND.items():
        for name, points in scenarios.items():
            write_folder(tmp_path / "sim-band" / variant / name, points, "sim")
    return tmp_path / "sim-band"


def test_band_envelope_coverage_and_width_by_hand(suite, band_root):
    report, pairs = validation.build_report(*suite, band_root=band_root)
    bands = {(p.scenario, p.point, p.node): (p.band_low, p.band_high) for p in pairs}
    # alpha p1: sim 1.188 / 2.2, low 1.15 / 1.9, high 1.25 / 2.5 -> RT 1.15..1.25 (hw 1.1 out),
    # nRT 1.9..2.5 (hw 2.0 in). p2 (only low): sim 1.02 / 2.4, low 1.0 / 2.2 -> RT 1.0..1.02
    # (hw 1.02 in: the edge counts), nRT 2.2..2.4 (hw 3.0 out). beta p4: sim 1.30 / 5.5, low
    # 1.2 / 4.8, high 1.35 / 5.2 -> RT 1.2..1.35 (hw 1.25 in), nRT 4.8..5.5 (hw 5.0 in).
    assert bands[("alpha", "p0000000001", "rt")] == pytest.approx((1.15, 1.25))
    assert bands[("alpha", "p0000000001", "nrt")] == pytest.approx((1.9, 2.5))
    assert bands[("alpha", "p0000000002", "rt")] == pytest.approx((1.0, 1.02))
    assert bands[("alpha", "p0000000002", "nrt")] == pytest.approx((2.2, 2.4))
    assert bands[("beta", "p0000000004", "rt")] == pytest.approx((1.2, 1.35))
    assert bands[("beta", "p0000000004", "nrt")] == pytest.approx((4.8, 5.5))
    alpha = report["scenarios"][0]["band"]
    assert alpha["variants"] == ["m-x-high", "m-x-low"]
    assert (alpha["rt"]["points"], alpha["rt"]["covered"]) == (2, 1)
    assert alpha["rt"]["median_width"] == pytest.approx(0.06)           # 0.10, 0.02
    assert alpha["nrt"]["coverage_pct"] == pytest.approx(50.0)
    assert alpha["nrt"]["median_width"] == pytest.approx(0.4)           # 0.6, 0.2
    band = report["band"]
    assert band["variants"] == ["m-x-high", "m-x-low"]
    assert (band["rt"]["points"], band["rt"]["covered"]) == (3, 2)
    assert band["rt"]["median_width"] == pytest.approx(0.10)            # 0.10, 0.02, 0.15
    assert band["nrt"]["coverage_pct"] == pytest.approx(200 / 3)
    assert band["nrt"]["median_width"] == pytest.approx(0.6)            # 0.6, 0.2, 0.7
    assert "one-at-a-time" in band["definition"]
    assert len(band["warnings"]) == 1
    assert band["warnings"][0].startswith(
        f"alpha: band folder {band_root / 'm-x-high' / 'alpha'} lacks 1 of 2 point(s) "
        "(p0000000002)")
    point = next(p for p in report["points"] if p["point"] == "p0000000002" and p["node"] == "rt")
    assert (point["band_low"], point["band_high"]) == pytest.approx((1.0, 1.02))
    # The errors are the nominal run's, band or not.
    plain, _ = validation.build_report(*suite)
    assert report["overall"]["rt"] == plain["overall"]["rt"]


def test_band_in_report_files_and_figure(suite, band_root, tmp_path):
    out = tmp_path / "out"
    done = run_cli("validate", *suite, "--out", out, "--band-root", band_root)
    assert done.returncode == 0, done.stderr
    assert ("prediction band (2 band platform(s) of the sim model): hw inside it at RT 2 of 3 "
            "(67 %) points, median width 0.100; nRT 2 of 3 (67 %) points, median width 0.600"
            in done.stdout)
    assert "warning: alpha: band folder" in done.stdout
    report = validation.load_report(out / "report.json")
    assert report["band"]["rt"]["covered"] == 2
    md = (out / "report.md").read_text()
    assert "## Prediction band" in md and "one-at-a-time" in md
    assert "| alpha | 2 | 1 of 2 (50 %) | 0.060 | 1 of 2 (50 %) | 0.400 |" in md
    assert "| **all** | 2 | 2 of 3 (67 %) | 0.100 | 2 of 3 (67 %) | 0.600 |" in md
    assert "| alpha | p0000000002 | rt | 1.020 | 1.020–1.020 | 1.020 | 1.000–1.020 |" in md
    assert "prediction band" in validation.readme_section(report, "f.png")
    assert_figure_files(out, "validation_scatter")


def test_figure_draws_the_band_on_sim_points():
    from analysis.figures import validation as figure
    stat = validation.Stat.of
    pairs = [validation.Pair("a", "p1", "rt", stat([1.1]), stat([1.2]), 1.15, 1.3),
             validation.Pair("a", "p2", "nrt", stat([2.0]), stat([2.2]), 1.9, 2.5),
             # a band beside the sim mean (bounds on one side) and one with a NaN bound
             validation.Pair("a", "p3", "nrt", stat([3.0]), stat([3.3]), 3.4, 3.6),
             validation.Pair("a", "p4", "nrt", stat([4.0]), stat([4.1]), math.nan, 4.3),
             validation.Pair("a", "p5", "rt", stat([1.05]), stat([1.06]))]        # no band
    fig = figure.draw(pairs, ["a"], {}, validation.EXCESS_MIN, "note")
    rt, nrt, excess = fig.axes[:3]

    def band_segments(ax):            # the wide bars: the band's errorbar containers
        return sorted(tuple(round(v, 6) for v in (s[0][1], s[1][1]))
                      for c in ax.containers if c.lines[2] and
                      c.lines[2][0].get_linewidth() == figure.BAND_STYLE["elinewidth"]
                      for s in c.lines[2][0].get_segments())

    assert band_segments(rt) == [(1.15, 1.3)]
    # p3: 3.4..3.6 lies above the sim mean 3.3: only the part above it (3.3..3.6); p4: the
    # NaN side draws nothing (4.1..4.3).
    assert band_segments(nrt) == [(1.9, 2.5), (3.3, 3.6), (4.1, 4.3)]
    assert band_segments(excess)[0] == pytest.approx((0.15, 0.3))       # RT p1, minus 1
    assert "sim prediction band" in [t.get_text() for t in fig.legends[0].get_texts()]
    plain = figure.draw(pairs[-1:], ["a"], {}, validation.EXCESS_MIN, "note")
    assert "sim prediction band" not in [t.get_text() for t in plain.legends[0].get_texts()]


def test_no_band_leaves_the_report_as_it_was(suite, tmp_path):
    empty = tmp_path / "no-variants"
    empty.mkdir()
    now = validation.datetime(2026, 1, 2, tzinfo=validation.timezone.utc)
    plain, _ = validation.build_report(*suite, now=now)
    assert "band" not in plain and all("band" not in s for s in plain["scenarios"])
    assert all("band_low" not in p for p in plain["points"])
    with_empty_root, _ = validation.build_report(*suite, now=now, band_root=empty)
    assert with_empty_root == plain
    md = validation.markdown(validation._clean(plain))
    assert "Prediction band" not in md and "sim band" not in md
    assert "| scenario | point | node | hw | hw min–max | sim | error | excess error |" in md
    assert "prediction band" not in validation.readme_section(plain, "f.png")
    done = run_cli("validate", *suite, "--out", tmp_path / "out", "--band-root",
                   tmp_path / "missing")
    assert done.returncode == 2 and "no such folder" in done.stderr


def test_a_variant_without_a_run_of_a_scenario_is_said(suite, band_root):
    import shutil
    shutil.rmtree(band_root / "m-x-low" / "beta")
    report, pairs = validation.build_report(*suite, band_root=band_root)
    beta = report["scenarios"][1]["band"]
    assert beta["variants"] == ["m-x-high"]
    assert [(p.band_low, p.band_high) for p in pairs if p.scenario == "beta"
            and p.node == "rt"] == [pytest.approx((1.30, 1.35))]
    assert any(w.startswith("beta: no run on band platform m-x-low") for w in
               report["band"]["warnings"])


# Scale validation (issue 24): scenarios of k co-runners, every nRT node paired, errors per k.
# scenario -> (k, point -> [(rt, nrt per node...) per repetition]); node names from the manifest.
SCALE_HW = {
    "scale-k1": (1, {"p0000000011": [(1.0, 2.0)], "p0000000012": [(1.25, 1.0)]}),
    "scale-k3": (3, {"p0000000021": [(2.0, 2.0, 4.0, 1.0)], "p0000000022": [(1.6, 1.0, 1.0, 2.0)]}),
}
SCALE_SIM = {
    "scale-k1": {"p0000000011": [(1.08, 2.2)], "p0000000012": [(1.25, 0.95)]},
    "scale-k3": {"p0000000021": [(2.2, 2.0, 5.0, 1.0)], "p0000000022": [(1.2, 1.1, 1.0, 2.4)]},
}


def write_scale_folder(folder, k, points, backend):
    """A results folder of an RT node and k nRT nodes (nrt_, nrt1_, ... name, workload and
    slowdown columns, as points.csv has them) with its scenario's nodes in the manifest."""
    folder.mkdir(parents=True)
    extra = ["rt_name", "nrt_name"] + [f"nrt{i}_{c}" for i in range(1, k)
                                       for c in ("name", "workload", "slowdown")]
    header = resultgen.FIXED_COLUMNS + resultgen.EXTRA_COLUMNS + extra
    with (folder / "points.csv").open("w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(header)
        for pid, reps in points.items():
            for rep, (rt, *nrt) in enumerate(reps):
                cells = {"point": pid, "rep": rep, "backend": backend,
                         "rt_workload": "bandwidth_read_llc",
                         "nrt_workload": "bandwidth_read_llc", "policy": "interval",
                         "sampling": "self", "scope": "core", "threshold_pct": 20,
                         "sampling_period_us": 1000, "regulation_period_us": 5000,
                         "rt_slowdown": rt, "nrt_slowdown": nrt[0], "platform": "host",
                         "rt_name": "rt0", "nrt_name": "co1"}
                for i in range(1, k):
                    cells[f"nrt{i}_name"] = f"co{i + 1}"
                    cells[f"nrt{i}_workload"] = "bandwidth_read_llc"
                    cells[f"nrt{i}_slowdown"] = nrt[i]
                w.writerow([cells.get(c, "") for c in header])
    nodes = {"controller": {"core": k}, "rt": [{"name": "rt0", "core": 0}],
             "nrt": [{"name": f"co{i}", "core": i} for i in range(1, k + 1)]}
    (folder / "manifest.json").write_text(json.dumps({
        "schema_version": 1, "backend": backend, "status": "complete",
        "start_time": "2026-01-01T00:00:00Z", "end_time": "2026-01-01T00:10:00Z",
        "tool": {"name": "rosguard", "version": "0.1.0", "git_revision": "abc123"},
        "host": {"hostname": "testhost", "cpu_model": "Test CPU", "cpus_online": 16},
        "scenario": {"given": {"description": f"checks {folder.name}", "nodes": nodes}}}))


@pytest.fixture
def scale_suite(tmp_path):
    for name, (k, points) in SCALE_HW.items():
        write_scale_folder(tmp_path / "hw" / name, k, points, "hw")
        write_scale_folder(tmp_path / "sim" / name, k, SCALE_SIM[name], "sim")
    return tmp_path / "hw", tmp_path / "sim"


def test_every_corunner_is_paired_and_the_errors_are_given_per_k(scale_suite):
    report, pairs = validation.build_report(*scale_suite)
    k3 = next(s for s in report["scenarios"] if s["name"] == "scale-k3")
    assert k3["corunners"] == 3
    # nRT errors per node: co1 0 %, 10 % -> 5 %; co2 25 %, 0 % -> 12.5 %; co3 0 %, 20 % -> 10 %.
    assert [(n["name"], n["index"]) for n in k3["nrt_nodes"]] == [("co1", 0), ("co2", 1),
                                                                 ("co3", 2)]
    assert [n["mape_pct"] for n in k3["nrt_nodes"]] == pytest.approx([5.0, 12.5, 10.0])
    # Over every co-runner: (0 + 10 + 25 + 0 + 0 + 20) / 6.
    assert k3["nrt"]["pairs"] == 6
    assert k3["nrt"]["mape_pct"] == pytest.approx(55.0 / 6)
    # RT k3: |2.2 - 2| / 2 = 10 %, |1.2 - 1.6| / 1.6 = 25 % -> 17.5 %.
    assert k3["rt"]["mape_pct"] == pytest.approx(17.5)
    per_k = {row["k"]: row for row in report["per_k"]}
    assert sorted(per_k) == [1, 3]
    assert per_k[1]["scenarios"] == ["scale-k1"] and per_k[1]["points"] == 2
    # k = 1: RT 8 %, 0 % -> 4 %; nRT 10 %, 5 % -> 7.5 %.
    assert per_k[1]["rt"]["mape_pct"] == pytest.approx(4.0)
    assert per_k[1]["nrt"]["mape_pct"] == pytest.approx(7.5)
    assert per_k[1]["goals"]["nrt_mape"]["status"] == "met"
    assert per_k[3]["nrt"]["mape_pct"] == pytest.approx(55.0 / 6)
    assert per_k[3]["goals"]["rt_mape"]["status"] == "missed"
    assert per_k[3]["nrt_nodes"] == {"nodes": 3, "min_mape_pct": pytest.approx(5.0),
                                     "max_mape_pct": pytest.approx(12.5),
                                     "worst": "scale-k3/co2"}
    # Overall pools every node: nRT pairs 2 (k1) + 6 (k3).
    assert report["overall"]["nrt"]["pairs"] == 8
    assert {(p.name, p.index) for p in pairs if p.scenario == "scale-k3" and p.node == "nrt"} \
        == {("co1", 0), ("co2", 1), ("co3", 2)}


def test_the_report_gives_errors_per_k_and_the_skipped_scenarios(scale_suite, tmp_path):
    out = tmp_path / "out"
    done = run_cli("validate", *scale_suite, "--out", out,
                   "--skipped", "scale-k7-llc=needs 8 CPUs (cores 0-7), this host has 2")
    assert done.returncode == 0, done.stderr
    assert "per number of co-runners k:" in done.stdout
    assert "skipped: scale-k7-llc: needs 8 CPUs (cores 0-7), this host has 2" in done.stdout
    md = (out / "report.md").read_text()
    assert "## Errors per number of co-runners (k)" in md
    assert "| 3 | scale-k3 | 2 | 17.5 % **missed** | 9.2 % met | 5.0 % – 12.5 % (3 nodes; " \
           "worst scale-k3/co2) |" in md
    assert "| 1 | scale-k1 | 2 | 4.0 % met | 7.5 % met | 7.5 % |" in md
    assert "- **scale-k7-llc**: needs 8 CPUs (cores 0-7), this host has 2" in md
    assert "  - nRT MAPE per node: co1 5.0 %, co2 12.5 %, co3 10.0 %" in md
    assert "| scale-k3 | p0000000021 | nrt co3 |" in md
    report = json.loads((out / "report.json").read_text())
    assert report["skipped"] == [{"scenario": "scale-k7-llc",
                                  "reason": "needs 8 CPUs (cores 0-7), this host has 2"}]
    assert [row["k"] for row in report["per_k"]] == [1, 3]
    assert_figure_files(out, validation.FIGURE_STEM)
    # The figure's fourth panel: MAPE per k, RT and nRT, the per-node range as a bar at k = 3.
    fig = validation._figure(*validation.build_report(*scale_suite))
    panel = fig.axes[3]
    lines = {line.get_label(): line for line in panel.get_lines()}
    rt = lines["RT MAPE"]
    assert list(rt.get_xdata()) == [1, 3]
    assert list(rt.get_ydata()) == pytest.approx([4.0, 17.5])


def test_a_suite_of_skipped_scenarios_only_is_reported(tmp_path):
    (tmp_path / "hw").mkdir()
    report, pairs = validation.build_report(tmp_path / "hw", tmp_path / "sim", [],
                                            skipped=[{"scenario": "scale-k3-llc",
                                                      "reason": "needs 4 CPUs"}])
    assert report["scenarios"] == [] and report["per_k"] == [] and not pairs
    assert report["skipped"][0]["scenario"] == "scale-k3-llc"


# The machine state (tools/validate.sh: STATE_DIR/<scenario>.json, the DRAM-interference probes
# right before and after the scenario's hw run, against the state the host model was calibrated
# in: `rosguard platform contention`'s output).
def probe(ratio, matches, model=1.74):
    """One contention probe as `rosguard platform contention --out F` writes it."""
    return {"cores": [0, 1], "working_set_kb": 131072, "ratio": ratio, "ci95_pct": 2.1,
            "rounds": 7, "date": "2026-11-28T07:40:00Z",
            "model": None if model is None else {
                "ratio": model, "ci95_pct": 1.8, "cores": [0, 1], "working_set_kb": 131072,
                "date": "2026-11-28T07:30:00Z"},
            "matches": matches}


def write_state(folder, name, before, after, waited_s=12.5, attempts=1):
    """STATE_DIR/<name>.json; a probe of None is left out (as when it failed)."""
    folder.mkdir(parents=True, exist_ok=True)
    state = {"waited_s": waited_s, "attempts": attempts}
    state.update({k: p for k, p in (("before", before), ("after", after)) if p is not None})
    (folder / f"{name}.json").write_text(json.dumps(state))


def without_state(report):
    """The report without what the machine state adds, to compare the rest."""
    rest = {k: v for k, v in report.items() if k not in ("state_dir", "in_model_state")}
    rest["scenarios"] = [{k: v for k, v in s.items() if k != "machine_state"}
                         for s in report["scenarios"]]
    return rest


def without_state_lines(md):
    """report.md's lines without the state line and the summary table's state column."""
    lines, in_table = [], False
    for line in md.splitlines():
        in_table = "DRAM state" in line or (in_table and line.startswith("|"))
        if not line.startswith("machine state:"):
            lines.append(line.rsplit(" | ", 1)[0] if in_table else line)
    return lines


def test_every_scenario_in_the_model_s_state(suite, tmp_path):
    out = tmp_path / "out"
    write_state(out / "state", "alpha", probe(1.72, True), probe(1.70, True))
    write_state(out / "state", "beta", probe(1.75, True), probe(1.73, True), waited_s=3.0)
    done = run_cli("validate", *suite, "--out", out)
    assert done.returncode == 0, done.stderr
    report = json.loads((out / "report.json").read_text())
    assert report["scenarios"][0]["machine_state"] == {
        "before": 1.72, "after": 1.70, "model": 1.74, "matches": True, "waited_s": 12.5,
        "attempts": 1, "alike": None, "other_way": None, "speed_before": None,
        "speed_after": None}
    assert "in_model_state" not in report
    md = (out / "report.md").read_text()
    assert "| DRAM state (beside one reader) |" in md
    assert "| alpha | 2 | 4.0 % met | 15.0 % **missed** |" in md
    assert md.count("| 1.72x / 1.70x, model 1.74x |") == 1
    assert "| 1.75x / 1.73x, model 1.74x |" in md
    assert "| 2 of 2 in the model's state |" in md
    assert "in the model's state**" not in md and "differs" not in md
    line = ("machine state: 2 of 2 scenarios measured in the model's DRAM-interference state "
            f"(the probe: {validation.PROBE_WORDS}, before and after each hw run); waited 16 s "
            "for it.")
    assert line in md.splitlines()
    assert line[:-1] in done.stdout.splitlines()
    block = validation.readme_section(validation.load_report(out / "report.json"), "f.png")
    assert ("Machine state: 2 of 2 scenarios measured in the model's DRAM-interference "
            "state.") in block
    assert "| 1.72x / 1.70x, model 1.74x |" in block


def test_a_scenario_in_another_state_is_marked_and_left_out_of_the_extra_row(suite, tmp_path):
    out, states = tmp_path / "out", tmp_path / "probes"
    write_state(states, "alpha", probe(1.72, True), probe(1.70, True))
    write_state(states, "beta", probe(1.02, False), probe(1.71, True), waited_s=300.0,
                attempts=2)
    done = run_cli("validate", *suite, "--out", out, "--state-dir", states)
    assert done.returncode == 0, done.stderr
    report = validation.load_report(out / "report.json")
    assert report["state_dir"] == str(states)
    assert report["scenarios"][1]["machine_state"] == {
        "before": 1.02, "after": 1.71, "model": 1.74, "matches": False, "waited_s": 300.0,
        "attempts": 2, "alike": None, "other_way": None, "speed_before": None,
        "speed_after": None}
    # The extra row: the errors of alpha alone, as a report of alpha alone has them overall.
    alone, _ = validation.build_report(*suite, ["alpha"])
    mine = report["in_model_state"]
    assert mine["scenarios"] == ["alpha"] and mine["points"] == 2
    for node in ("rt", "nrt"):
        assert mine[node]["mape_pct"] == pytest.approx(alone["overall"][node]["mape_pct"])
        assert mine[node]["excess_error_pct"] == pytest.approx(
            alone["overall"][node]["excess_error_pct"])
    assert mine["goals"] == validation._restore(validation._clean(alone["overall"]["goals"]))
    assert mine["rt"]["mape_pct"] != pytest.approx(report["overall"]["rt"]["mape_pct"]) or \
        mine["nrt"]["mape_pct"] != pytest.approx(report["overall"]["nrt"]["mape_pct"])
    md = (out / "report.md").read_text()
    assert "| beta | 1 | " in md and "| **1.02x / 1.71x, model 1.74x: differs** |" in md
    assert "| **all** | 3 | 4.0 % met | 13.3 % **missed** |" in md
    assert ("| **in the model's state** | 2 | 4.0 % met | 15.0 % **missed** | 88.0 % (n=1) "
            "**missed** | 25.0 % (n=2) **missed** | 18.2 % / 0.0 % | – / – | "
            "1 scenario(s) |") in md
    assert md.index("| **all** |") < md.index("| **in the model's state** |")
    assert ("machine state: 1 of 2 scenarios measured in the model's DRAM-interference state "
            f"(the probe: {validation.PROBE_WORDS}, before and after each hw run); waited 312 s "
            "for it. In another state: beta; their errors compare the model with the machine "
            "in another state.") in md
    # The goals stay marked over every scenario.
    plain, _ = validation.build_report(*suite)
    assert validation.verdict(report) == validation.verdict(plain)
    assert f"**{validation.verdict(plain)}.**" in md
    assert report["overall"]["goals"] == validation._restore(
        validation._clean(plain["overall"]["goals"]))
    block = validation.readme_section(report, "f.png")
    assert ("Machine state: 1 of 2 scenarios measured in the model's DRAM-interference state. "
            "In another state: beta; their errors compare the model with the machine in "
            "another state.") in block
    assert "| **in the model's state** | 2 |" in block


def test_without_state_files_the_state_is_not_probed_and_nothing_else_changes(suite, tmp_path):
    out = tmp_path / "out"
    done = run_cli("validate", *suite, "--out", out)
    assert done.returncode == 0, done.stderr
    report = validation.load_report(out / "report.json")
    assert all(s["machine_state"] == dict.fromkeys(validation.STATE_KEYS)
               for s in report["scenarios"])
    assert "in_model_state" not in report
    md = (out / "report.md").read_text()
    assert ("| alpha | 2 | 4.0 % met | 15.0 % **missed** | 88.0 % (n=1) **missed** | 25.0 % "
            "(n=2) **missed** | 18.2 % / 0.0 % | – / – | not probed |") in md
    assert "| **all** | 3 |" in md and md.count("not probed |") == 3
    assert ("machine state: not probed (the DRAM interference between the CPUs during the hw "
            "runs is not known).") in md.splitlines()
    # Everything else as with every scenario probed in the model's state.
    now = validation.datetime(2026, 1, 2, tzinfo=validation.timezone.utc)
    states = tmp_path / "probes"
    for name in ("alpha", "beta"):
        write_state(states, name, probe(1.72, True), probe(1.70, True))
    probed, _ = validation.build_report(*suite, now=now, state_dir=states)
    plain, _ = validation.build_report(*suite, now=now, state_dir=tmp_path / "missing")
    assert all(not any(s["machine_state"].values()) for s in plain["scenarios"])
    assert without_state(plain) == without_state(probed)
    assert without_state_lines(validation.markdown(validation._clean(plain))) == \
        without_state_lines(validation.markdown(validation._clean(probed)))
    # A report from before the probes (no machine_state) still gives the README block.
    old = without_state(report)
    assert "Machine state: not probed." in validation.readme_section(old, "f.png")


# before / after: a probe that matched (True), did not (False) or is missing (None).
@pytest.mark.parametrize("before, after, matches, cell", [
    (None, None, None, "not probed"),
    (True, None, None, "1.70x / n/a, model 1.74x"),
    (False, None, False, "**1.70x / n/a, model 1.74x: differs**"),
    (True, False, False, "**1.70x / 1.60x, model 1.74x: differs**"),
    (None, True, None, "n/a / 1.60x, model 1.74x"),
], ids=["none", "before-matched", "before-differs", "after-differs", "after-matched"])
def test_a_missing_probe_leaves_the_state_unknown_unless_the_other_differs(
        tmp_path, before, after, matches, cell):
    write_state(tmp_path, "s", probe(1.7, before) if before is not None else None,
                probe(1.6, after) if after is not None else None)
    found = validation.machine_state(tmp_path, "s")
    assert found["matches"] is matches
    assert validation._state_cell(found) == cell


def with_other_way(p, reverse, alike):
    """The probe with the other way round's ratio and whether the two ways agreed (None: the
    state changed while probing)."""
    return dict(p, reverse=dict(p, cores=[1, 0], ratio=reverse), alike=alike)


@pytest.mark.parametrize("before, after, alike, cell", [
    ((1.36, False), (1.70, True), False,
     "1.72x / 1.70x, model 1.74x; the other way 1.36x: CPUs unlike"),
    ((1.75, True), (1.30, False), False,
     "1.72x / 1.70x, model 1.74x; the other way 1.30x: CPUs unlike"),
    ((1.75, True), (1.69, True), True, "1.72x / 1.70x, model 1.74x"),
    ((1.02, None), (1.69, True), None, "1.72x / 1.70x, model 1.74x"),
], ids=["before-unlike", "after-unlike", "alike", "not-compared"])
def test_two_cpus_slowed_differently_are_said_with_the_other_way_s_ratio(
        tmp_path, before, after, alike, cell):
    write_state(tmp_path, "s", with_other_way(probe(1.72, True), *before),
                with_other_way(probe(1.70, True), *after))
    found = validation.machine_state(tmp_path, "s")
    assert found["alike"] is alike
    assert found["other_way"] == (before[0] if before[1] is not False and after[1] is not False
                                  else next(r for r, a in (before, after) if a is False))
    assert validation._state_cell(found) == cell


def test_the_host_s_speed_against_the_model_s_is_in_the_cell(tmp_path):
    # The reader alone 24 % faster than the model's before the run, 3 % after; the probe before
    # found another interference state.
    write_state(tmp_path, "s", dict(probe(1.72, False), speed_offset_pct=-24.1),
                dict(probe(1.70, True), speed_offset_pct=-3.04))
    found = validation.machine_state(tmp_path, "s")
    assert (found["speed_before"], found["speed_after"]) == (-24.1, -3.04)
    assert validation._state_cell(found) == \
        "**1.72x / 1.70x, model 1.74x; speed -24.1 % / -3.0 %: differs**"
    # One probe without it (a model from before rosguard recorded the speed).
    write_state(tmp_path, "t", probe(1.72, True), dict(probe(1.70, True), speed_offset_pct=4.0))
    assert validation._state_cell(validation.machine_state(tmp_path, "t")) == \
        "1.72x / 1.70x, model 1.74x; speed – / +4.0 %"


def test_a_model_without_a_state_leaves_it_unknown(tmp_path):
    write_state(tmp_path, "s", probe(1.7, None, model=None), probe(1.6, None, model=None))
    found = validation.machine_state(tmp_path, "s")
    assert (found["before"], found["model"], found["matches"]) == (1.7, None, None)
    assert validation._state_cell(found) == "1.70x / 1.60x, model n/a"
    report = {"scenarios": [{"name": "s", "machine_state": found}]}
    assert validation.state_summary(report, short=True) == (
        "machine state: 0 of 1 scenarios measured in the model's DRAM-interference state. Not "
        "known for s")


@pytest.mark.parametrize("text, words", [
    ("{not json", "cannot read a machine-state file"),
    ("[1.7]", "not a machine-state file (not a JSON object)"),
    ('{"before": {"ratio": "fast", "matches": true}}',
     "not a machine-state file ('before.ratio' is \"fast\", not a number or null)"),
    ('{"after": {"ratio": 1.7, "matches": "yes"}}',
     "'after.matches' is \"yes\", not true or false or null"),
    ('{"before": 1.7}', "'before' is not an object"),
    ('{"attempts": 1.5}', "'attempts' is 1.5, not a whole number or null"),
    ('{"before": {"ratio": 1.7, "alike": "no"}}',
     "'before.alike' is \"no\", not true or false or null"),
    ('{"after": {"ratio": 1.7, "reverse": 1.3}}', "'after.reverse' is not an object"),
    ('{"before": {"ratio": 1.7, "speed_offset_pct": "fast"}}',
     "'before.speed_offset_pct' is \"fast\", not a number or null"),
], ids=["not-json", "not-an-object", "ratio-text", "matches-text", "probe-number",
        "attempts-fraction", "alike-text", "reverse-number", "speed-text"])
def test_a_malformed_state_file_is_an_input_error_naming_it(suite, tmp_path, text, words):
    out = tmp_path / "out"
    (out / "state").mkdir(parents=True)
    write_state(out / "state", "alpha", probe(1.72, True), probe(1.70, True))
    (out / "state" / "beta.json").write_text(text)
    done = run_cli("validate", *suite, "--out", out)
    assert done.returncode == 2, done.stderr
    assert done.stderr.startswith(f"error: {out / 'state' / 'beta.json'}: ")
    assert words in done.stderr and "Traceback" not in done.stderr
    assert not (out / "report.md").exists() and not (out / "report.json").exists()


def test_the_hw_run_s_precision_is_given_per_scenario(suite, tmp_path):
    """An hw run with adaptive repetitions: its target, cap, the fewest and most repetitions
    a point took and its summary, in report.json and on the scenario's line in report.md; a
    run without a precision in its manifest gives None and its fixed repetitions."""
    manifest = suite[0] / "alpha" / "manifest.json"
    doc = json.loads(manifest.read_text())
    doc["precision"] = {"target_pct": 3.0, "max_repetitions": 10, "min_repetitions": 5,
                        "summary": "slowdown 95 % CI within 3 % on 1 of 2 point(s)",
                        "points": {"p0000000001": {"repetitions": 7},
                                   "p0000000002": {"repetitions": 10}}}
    manifest.write_text(json.dumps(doc))
    out = tmp_path / "out"
    assert run_cli("validate", *suite, "--out", out).returncode == 0
    report = json.loads((out / "report.json").read_text())
    by_name = {s["name"]: s for s in report["scenarios"]}
    assert by_name["alpha"]["hw_precision"] == {
        "target_pct": 3.0, "max_repetitions": 10, "fewest": 7, "most": 10,
        "summary": "slowdown 95 % CI within 3 % on 1 of 2 point(s)"}
    assert set(by_name["beta"]["hw_precision"].values()) == {None}
    md = (out / "report.md").read_text()
    assert "- **alpha** (2 points, hw x7-10 / sim x2 repetitions;" in md
    assert "  - hw precision: slowdown 95 % CI within 3 % on 1 of 2 point(s)" in md
    assert "- **beta** (1 points, hw x1 / sim x1 repetitions;" in md

"""tools/hw_audit.py: the per-test table of failures, skips and unchecked passes, from ctest's
junit reports (written here by hand, as ctest writes them)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("hw_audit", ROOT / "tools" / "hw_audit.py")
hw_audit = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(hw_audit)


def report(path: Path, cases) -> Path:
    """A junit report with (name, status, output) test cases."""
    body = []
    for name, status, out in cases:
        inner = {"fail": '<failure message="Failed"/>', "notrun": "<skipped/>"}.get(status, "")
        body.append(f'<testcase name="{name}" status="{status}">{inner}'
                    f"<system-out>{out}</system-out></testcase>")
    path.write_text('<?xml version="1.0"?><testsuite>' + "".join(body) + "</testsuite>")
    return path


def test_the_table_counts_failures_skips_and_unchecked_runs_per_kind_of_pass(tmp_path):
    reports = [
        ("idle", report(tmp_path / "1.xml", [("hw/a", "run", ""), ("hw/b", "run", ""),
                                             ("hw/c", "notrun", "SKIPPED: no PMU")])),
        ("busy", report(tmp_path / "2.xml", [("hw/a", "fail", ""),
                                             ("hw/b", "run", "SKIPPED (the check): shared"),
                                             ("hw/c", "notrun", "SKIPPED: no PMU")])),
        ("busy", tmp_path / "cut-short.xml"),  # no report: the pass is not counted
    ]
    passes, tests = hw_audit.tally(reports)
    assert passes == {"idle": 1, "busy": 1}
    assert tests["hw/a"]["busy"]["failed"] == 1 and tests["hw/a"]["idle"]["failed"] == 0
    assert tests["hw/b"]["busy"]["unchecked"] == 1
    assert tests["hw/c"]["idle"]["skipped"] == 1
    text = hw_audit.table(passes, tests)
    assert "| hw/a | 0 / 0 / 0 of 1 | 1 / 0 / 0 of 1 |" in text
    assert "| hw/b | 0 / 0 / 0 of 1 | 0 / 0 / 1 of 1 |" in text
    assert "Passes: 1 idle, 1 busy" in text

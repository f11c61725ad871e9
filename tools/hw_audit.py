#!/usr/bin/env python3
"""Runs the timing-dependent tests again and again, idle and beside one busy process, and counts.

Passes alternate: an idle pass (nothing else started), then a busy pass (one process spinning
on the CPU, unpinned, as a user's other work would), and so on; each pass is one
`ctest -R REGEX` in BUILD with a junit report. At the end (or when interrupted) it prints, per
test that failed or skipped at least once, its failures and skips per kind of pass, and
writes the same table to OUT/audit.md:

    python3 tools/hw_audit.py [--build build] [--passes 10] [--regex '^hw/']
        [--out results/hw-audit]

A test that skips its check in a pass ("SKIPPED (...)" in its output, the check part only) is
counted apart: it passed without checking.
"""

from __future__ import annotations

import argparse
import collections
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

BUSY = "while True: pass"


def run_pass(build: Path, regex: str, report: Path, busy: bool) -> None:
    spinner = subprocess.Popen([sys.executable, "-c", BUSY]) if busy else None
    try:
        subprocess.run(["ctest", "-R", regex, "--timeout", "300", "--output-on-failure",
                        "--output-junit", str(report.resolve())], cwd=build,
                       stdout=(report.with_suffix(".txt")).open("w"), stderr=subprocess.STDOUT,
                       check=False)
    finally:
        if spinner:
            spinner.kill()
            spinner.wait()


def tally(reports) -> tuple:
    """(passes per kind, {test: {kind: Counter(runs, failed, skipped, unchecked)}})."""
    passes = collections.Counter()
    tests = collections.defaultdict(lambda: collections.defaultdict(collections.Counter))
    for kind, report in reports:
        try:
            root = ET.parse(report).getroot()
        except (ET.ParseError, OSError):
            continue  # a pass cut short writes no report
        passes[kind] += 1
        for case in root.iter("testcase"):
            c = tests[case.get("name")][kind]
            c["runs"] += 1
            out = "".join(x.text or "" for x in case.iter("system-out"))
            if case.find("failure") is not None or case.get("status") == "fail":
                c["failed"] += 1
            elif case.find("skipped") is not None or case.get("status") in ("notrun", "disabled"):
                c["skipped"] += 1
            elif "SKIPPED (" in out:
                c["unchecked"] += 1
    return passes, tests


def table(passes, tests) -> str:
    kinds = ("idle", "busy")
    lines = [f"Passes: {passes['idle']} idle, {passes['busy']} busy (one busy process beside).",
             "", "| test | " + " | ".join(f"{k}: failed / skipped / unchecked of runs"
                                         for k in kinds) + " |",
             "|---|" + "---|" * len(kinds)]
    quiet = 0
    for name in sorted(tests):
        t = tests[name]
        if not any(t[k]["failed"] or t[k]["skipped"] or t[k]["unchecked"] for k in kinds):
            quiet += 1
            continue
        cells = [f"{t[k]['failed']} / {t[k]['skipped']} / {t[k]['unchecked']} of {t[k]['runs']}"
                 for k in kinds]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    if len(lines) == 4:
        lines = lines[:1] + ["", "No test failed or skipped."]
    lines += ["", f"{quiet} {'other ' if len(lines) > 3 else ''}test(s) passed every run."]
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--build", type=Path, default=Path("build"))
    ap.add_argument("--passes", type=int, default=10, help="idle and busy passes in all")
    ap.add_argument("--regex", default="^hw/", help="ctest -R: the tests of a pass")
    ap.add_argument("--out", type=Path, default=Path("results") / "hw-audit")
    args = ap.parse_args()
    if not (args.build / "CTestTestfile.cmake").is_file():
        print(f"{args.build}: not a configured build folder (run make test first)",
              file=sys.stderr)
        sys.exit(2)
    args.out.mkdir(parents=True, exist_ok=True)
    reports = []
    try:
        for i in range(args.passes):
            kind = "idle" if i % 2 == 0 else "busy"
            report = args.out / f"pass-{i + 1:03d}-{kind}.xml"
            start = time.monotonic()
            run_pass(args.build, args.regex, report, kind == "busy")
            reports.append((kind, report))
            failed = sum(t[kind]["failed"] for t in tally([(kind, report)])[1].values())
            print(f"pass {i + 1}/{args.passes} ({kind}): {failed} failed, "
                  f"{time.monotonic() - start:.0f} s", flush=True)
    except KeyboardInterrupt:
        print("interrupted: the table counts the passes that completed", file=sys.stderr)
    text = table(*tally(reports))
    (args.out / "audit.md").write_text(text)
    sys.stdout.write(text)


if __name__ == "__main__":
    main()

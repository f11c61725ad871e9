#!/usr/bin/env python3
"""Keep docs/results.md's results-columns section equal to `rosguard list columns`.

The column dictionary lives in model/results/columns.cpp (the same one every results folder
gets as columns.json); docs/results.md shows it between <!-- columns:begin --> and
<!-- columns:end -->:
    python3 tools/columns_doc.py build/rosguard            # rewrite the section
    python3 tools/columns_doc.py build/rosguard --check    # exit 1 if it is out of date
"""
import argparse
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from analysis.markdown import splice  # noqa: E402
from analysis.results import InvalidInput  # noqa: E402

PAGE = ROOT / "docs" / "results.md"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rosguard", help="the rosguard executable")
    ap.add_argument("--check", action="store_true", help="only compare; exit 1 if different")
    args = ap.parse_args()
    table = subprocess.run([args.rosguard, "list", "columns"], check=True, capture_output=True,
                           text=True).stdout
    text = PAGE.read_text()
    try:
        fresh = splice(text, "columns", table, str(PAGE))
    except InvalidInput as e:
        sys.exit(str(e))
    if args.check:
        if fresh != text:
            print(f"{PAGE}: the results-columns section is out of date; regenerate: "
                  f"python3 tools/columns_doc.py {args.rosguard}")
            return 1
        return 0
    PAGE.write_text(fresh)
    return 0


if __name__ == "__main__":
    sys.exit(main())

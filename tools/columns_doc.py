#!/usr/bin/env python3
"""Keep README.md's results-columns section equal to `rosguard list columns`.

The column dictionary lives in model/results/columns.cpp (the same one every results folder
gets as columns.json); the README shows it between <!-- columns:begin --> and
<!-- columns:end -->:
    python3 tools/columns_doc.py build/rosguard            # rewrite the section
    python3 tools/columns_doc.py build/rosguard --check    # exit 1 if it is out of date
"""
import argparse
import subprocess
import sys
from pathlib import Path

README = Path(__file__).resolve().parent.parent / "README.md"
BEGIN, END = "<!-- columns:begin -->", "<!-- columns:end -->"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rosguard", help="the rosguard executable")
    ap.add_argument("--check", action="store_true", help="only compare; exit 1 if different")
    args = ap.parse_args()
    table = subprocess.run([args.rosguard, "list", "columns"], check=True, capture_output=True,
                           text=True).stdout
    text = README.read_text()
    head, begin, rest = text.partition(BEGIN)
    current, end, tail = rest.partition(END)
    if not begin or not end:
        sys.exit(f"{README}: the markers {BEGIN} / {END} are missing")
    fresh = "\n" + table
    if args.check:
        if current != fresh:
            print(f"{README}: the results-columns section is out of date; regenerate: "
                  f"python3 tools/columns_doc.py {args.rosguard}")
            return 1
        return 0
    README.write_text(head + BEGIN + fresh + END + tail)
    return 0


if __name__ == "__main__":
    sys.exit(main())

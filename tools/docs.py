#!/usr/bin/env python3
"""Regenerate the command transcripts of README.md and docs/, and check the pages.

A transcript is a command's real output, kept between markers that name the command:

    <!-- transcript:begin rosguard check scenarios/quickstart.json -->
    ```
    $ rosguard check scenarios/quickstart.json
    ...its stdout...
    ```
    <!-- transcript:end -->

    python3 tools/docs.py [--rosguard build/rosguard]   # run every command, rewrite the blocks
    python3 tools/docs.py --check                        # only check the pages (no build needed)

Commands run from the repository root with ROSGUARD_HOME set to it, in page order (README.md
first, then docs/ by name), so that a transcript may show a folder an earlier one wrote; only
stdout is kept (progress and warnings go to stderr). A command that exits non-zero stops the
regeneration and no page is written. --check fails on a `$ rosguard` line outside such markers
(it would go stale unnoticed), on a block whose first line is not its marker's command, and on
a relative link (or its #anchor, for a Markdown page) that does not resolve.
"""

from __future__ import annotations

import argparse
import os
import re
import shlex
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from analysis.markdown import blocks, replace_blocks  # noqa: E402
from analysis.results import InvalidInput  # noqa: E402

NAME = "transcript"
PROMPT = re.compile(r"^\s*\$ rosguard\b")
FENCE = re.compile(r"^\s*(```|~~~)")
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
EXTERNAL = ("http://", "https://", "mailto:")


def pages(root: Path) -> list[Path]:
    """README.md, then every Markdown page under docs/."""
    return [root / "README.md"] + sorted((root / "docs").rglob("*.md"))


def transcript(command: str, output: str) -> str:
    """The Markdown of one transcript block (between its markers)."""
    return f"```\n$ {command}\n{output}" + ("" if output.endswith("\n") or not output else "\n") \
        + "```\n"


def run(command: str, rosguard: Path, root: Path, where: str) -> str:
    argv = shlex.split(command)
    if not argv or argv[0] != "rosguard":
        raise InvalidInput(f"{where}: transcript command must start with 'rosguard': {command}")
    env = dict(os.environ, ROSGUARD_HOME=str(root))
    start = time.monotonic()
    # argv[0] "rosguard", as the page shows it: output that echoes the command (status on a
    # tune's folder) then reads the same whichever build ran it
    done = subprocess.run(argv, executable=rosguard, cwd=root, env=env, capture_output=True,
                          text=True)
    print(f"{where}: {command} ({time.monotonic() - start:.1f} s)", file=sys.stderr)
    if done.returncode != 0:
        raise InvalidInput(f"{where}: '{command}' exited {done.returncode}:\n{done.stderr}")
    return transcript(command, done.stdout)


def regenerate(root: Path, rosguard: Path) -> list[Path]:
    """Runs every transcript's command and rewrites the pages; returns the pages changed."""
    fresh = {}
    for page in pages(root):
        where = str(page.relative_to(root))
        text = page.read_text()
        fresh[page] = (text, replace_blocks(text, NAME,
                                            lambda c: run(c, rosguard, root, where), where))
    changed = [p for p, (old, new) in fresh.items() if old != new]
    for page in changed:
        page.write_text(fresh[page][1])
    return changed


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def anchors(text: str) -> set[str]:
    return {slug(m[1]) for m in re.finditer(r"^#{1,6} (.+)$", prose(text), re.MULTILINE)}


def prose(text: str) -> str:
    """text without fenced code blocks and inline code spans (line count kept)."""
    lines, fenced = [], False
    for line in text.split("\n"):
        if FENCE.match(line):
            fenced = not fenced
            lines.append("")
        else:
            lines.append("" if fenced else re.sub(r"`[^`]*`", "", line))
    return "\n".join(lines)


def check_links(page: Path, root: Path) -> list[str]:
    problems = []
    where = page.relative_to(root)
    for number, line in enumerate(prose(page.read_text()).split("\n"), 1):
        for target in LINK.findall(line):
            if target.startswith(EXTERNAL):
                continue
            path, _, anchor = target.partition("#")
            resolved = (page.parent / path).resolve() if path else page
            if not resolved.exists():
                problems.append(f"{where}:{number}: link to {target}: {path} does not exist")
            elif anchor and resolved.suffix == ".md" and anchor not in anchors(
                    resolved.read_text()):
                problems.append(f"{where}:{number}: link to {target}: no heading '#{anchor}' "
                                f"in {path or where}")
    return problems


def check_transcripts(page: Path, root: Path) -> list[str]:
    where = page.relative_to(root)
    text = page.read_text()
    try:
        found = blocks(text, NAME)
        replace_blocks(text, NAME, lambda _: "", str(where))  # balanced markers
    except InvalidInput as e:
        return [str(e)]
    problems = [f"{where}: the transcript of '{b.argument}' does not start with its command "
                f"(regenerate: make docs)"
                for b in found if not b.content.startswith(f"\n```\n$ {b.argument}\n")]
    inside = False
    for number, line in enumerate(text.split("\n"), 1):
        if line.startswith(f"<!-- {NAME}:begin"):
            inside = True
        elif line == f"<!-- {NAME}:end -->":
            inside = False
        elif not inside and PROMPT.match(line):
            problems.append(f"{where}:{number}: a '$ rosguard' transcript outside "
                            f"<!-- {NAME}:begin COMMAND --> / <!-- {NAME}:end --> markers "
                            f"(make docs regenerates only those)")
    return problems


def check(root: Path) -> list[str]:
    problems = []
    for page in pages(root):
        problems += check_links(page, root) + check_transcripts(page, root)
    return problems


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rosguard", type=Path, default=ROOT / "build" / "rosguard",
                    help="the rosguard executable (default: build/rosguard)")
    ap.add_argument("--check", action="store_true",
                    help="only check links and transcript markers; exit 1 on a problem")
    args = ap.parse_args()
    if args.check:
        problems = check(ROOT)
        for problem in problems:
            print(problem)
        return 1 if problems else 0
    try:
        changed = regenerate(ROOT, args.rosguard.resolve())
    except InvalidInput as e:
        print(f"docs: {e}", file=sys.stderr)
        return 1
    print("rewritten: " + (", ".join(str(p.relative_to(ROOT)) for p in changed) or "nothing"))
    problems = check(ROOT)
    for problem in problems:
        print(problem)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())

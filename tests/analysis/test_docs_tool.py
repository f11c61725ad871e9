"""tools/docs.py: transcripts regenerated between their markers, links and stray transcripts
found, on a small tree of pages and a stand-in rosguard (a shell script)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from analysis.results import InvalidInput

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("docs_tool", ROOT / "tools" / "docs.py")
docs_tool = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(docs_tool)

README = """# tool

## Commands

<!-- transcript:begin rosguard list policies -->
```
$ rosguard list policies
stale output
```
<!-- transcript:end -->

See [the guide](docs/guide.md#a-section), `[not a link](nowhere.md)`.
"""

GUIDE = """# Guide

## A section

Back to [the README](../README.md#commands) and a [figure](figures/f.png).

<!-- transcript:begin rosguard check "a b.json" -->
```
$ rosguard check "a b.json"
```
<!-- transcript:end -->
"""


@pytest.fixture
def tree(tmp_path):
    (tmp_path / "docs" / "figures").mkdir(parents=True)
    (tmp_path / "docs" / "figures" / "f.png").write_bytes(b"png")
    (tmp_path / "README.md").write_text(README)
    (tmp_path / "docs" / "guide.md").write_text(GUIDE)
    fake = tmp_path / "fake-rosguard"
    # prints its arguments one a line, and whether ROSGUARD_HOME is the tree; "fail" fails
    fake.write_text('#!/bin/sh\n[ "$1" = fail ] && { echo broken >&2; exit 3; }\n'
                    'for a in "$@"; do echo "arg: $a"; done\n'
                    '[ "$ROSGUARD_HOME" = "$PWD" ] && echo "home: the tree"\n'
                    'echo "progress" >&2\n')
    fake.chmod(0o755)
    return tmp_path


def test_a_clean_tree_passes(tree):
    assert docs_tool.check(tree) == []


def test_regenerate_runs_each_command_and_splices_its_stdout(tree):
    changed = docs_tool.regenerate(tree, tree / "fake-rosguard")
    assert changed == [tree / "README.md", tree / "docs" / "guide.md"]
    readme = (tree / "README.md").read_text()
    assert ("<!-- transcript:begin rosguard list policies -->\n```\n$ rosguard list policies\n"
            "arg: list\narg: policies\nhome: the tree\n```\n<!-- transcript:end -->") in readme
    assert "stale output" not in readme and "progress" not in readme
    assert "arg: a b.json\n" in (tree / "docs" / "guide.md").read_text()
    assert docs_tool.check(tree) == []
    assert docs_tool.regenerate(tree, tree / "fake-rosguard") == []  # nothing changes twice


def test_a_failing_command_writes_no_page(tree):
    (tree / "docs" / "guide.md").write_text(GUIDE.replace('check "a b.json"', "fail"))
    before = (tree / "README.md").read_text()
    with pytest.raises(InvalidInput, match=r"docs/guide.md: 'rosguard fail' exited 3:\nbroken"):
        docs_tool.regenerate(tree, tree / "fake-rosguard")
    assert (tree / "README.md").read_text() == before


def test_broken_links_and_anchors_are_found(tree):
    (tree / "docs" / "figures" / "f.png").unlink()
    (tree / "README.md").write_text(README.replace("#a-section", "#no-such-section"))
    assert docs_tool.check(tree) == [
        "README.md:12: link to docs/guide.md#no-such-section: no heading '#no-such-section' "
        "in docs/guide.md",
        "docs/guide.md:5: link to figures/f.png: figures/f.png does not exist"]


def test_a_transcript_outside_markers_is_found(tree):
    stray = README + "\n```\n$ rosguard tune x.json --rt-slowdown-max 1.2\nbest ...\n```\n"
    (tree / "README.md").write_text(stray)
    assert docs_tool.check(tree) == [
        "README.md:15: a '$ rosguard' transcript outside <!-- transcript:begin COMMAND --> / "
        "<!-- transcript:end --> markers (make docs regenerates only those)"]


def test_a_hand_edited_command_line_is_found(tree):
    (tree / "README.md").write_text(README.replace("$ rosguard list policies",
                                                   "$ rosguard list workloads"))
    problems = docs_tool.check(tree)
    assert len(problems) == 1 and "transcript of 'rosguard list policies'" in problems[0]


"""analysis.markdown: the one helper that rewrites generated blocks in Markdown files."""

from __future__ import annotations

import pytest

from analysis.markdown import blocks, markers, replace_blocks, splice
from analysis.results import InvalidInput

PAGE = ("intro\n<!-- table:begin -->\nold table\n<!-- table:end -->\n"
        "middle\n<!-- run:begin rosguard list -->\nold a\n<!-- run:end -->\n"
        "<!-- run:begin rosguard check x.json -->\n<!-- run:end -->\ntail\n")


def test_splice_replaces_the_block_and_keeps_the_rest():
    text = splice(PAGE, "table", "| a |\n", "page.md")
    assert text == PAGE.replace("old table\n", "| a |\n")
    assert splice(text, "table", "| a |", "page.md") == text  # a newline added where missing


def test_splice_needs_exactly_one_block():
    with pytest.raises(InvalidInput, match=r"page.md: expected one <!-- run:begin -->.*found 2"):
        splice(PAGE, "run", "x\n", "page.md")
    with pytest.raises(InvalidInput, match="found 0"):
        splice("no markers\n", "table", "x\n", "page.md")


def test_replace_blocks_renders_each_block_from_its_argument():
    text = replace_blocks(PAGE, "run", lambda arg: f"$ {arg}\n", "page.md")
    assert [b.argument for b in blocks(text, "run")] == ["rosguard list", "rosguard check x.json"]
    assert [b.content for b in blocks(text, "run")] == ["\n$ rosguard list\n",
                                                        "\n$ rosguard check x.json\n"]
    assert "old a" not in text and text.startswith("intro\n<!-- table:begin -->\nold table\n")
    assert text.endswith("<!-- run:end -->\ntail\n")


def test_unbalanced_markers_are_refused():
    half = PAGE.replace("<!-- run:end -->\ntail", "tail")
    with pytest.raises(InvalidInput, match=r"page.md: unbalanced.*2 begin, 1 end"):
        replace_blocks(half, "run", lambda arg: "x\n", "page.md")


def test_a_marker_quoted_within_a_line_is_text():
    quoted = "say `<!-- table:begin -->` and `<!-- table:end -->` here\n" + PAGE
    assert splice(quoted, "table", "new\n", "page.md").startswith(quoted.split("old")[0])


def test_markers():
    assert markers("columns") == ("<!-- columns:begin -->", "<!-- columns:end -->")
    assert markers("run", "rosguard list")[0] == "<!-- run:begin rosguard list -->"

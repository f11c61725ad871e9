"""Generated blocks in Markdown files.

A generated block sits between two HTML comments that a Markdown renderer does not show, each
at the start of a line (a marker quoted within a line is text, not a marker):

    <!-- NAME:begin -->            or, with an argument:   <!-- NAME:begin ARGUMENT -->
    ...generated text...
    <!-- NAME:end -->

``replace_blocks`` rewrites every block of one name from its argument (the docs transcripts:
the argument is the command); ``splice`` rewrites the one block of a name (the results columns,
the paper table, the sensitivity table, the validation block). Everything between the markers
is replaced; the text outside them is kept byte for byte.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Callable

from analysis.results import InvalidInput


@dataclass(frozen=True)
class Block:
    """One generated block: its argument (text after ``begin``, "" if none) and its text."""
    argument: str
    content: str


def _pattern(name: str) -> re.Pattern:
    name = re.escape(name)
    return re.compile(rf"^<!-- {name}:begin(?: (?P<argument>[^\n]*?))? -->"
                      rf"(?P<content>.*?)^<!-- {name}:end -->", re.DOTALL | re.MULTILINE)


def markers(name: str, argument: str = "") -> tuple[str, str]:
    """The begin and end markers of a block."""
    begin = f"<!-- {name}:begin{' ' + argument if argument else ''} -->"
    return begin, f"<!-- {name}:end -->"


def blocks(text: str, name: str) -> list[Block]:
    """Every block of ``name`` in text, in order."""
    return [Block(m["argument"] or "", m["content"]) for m in _pattern(name).finditer(text)]


def replace_blocks(text: str, name: str, render: Callable[[str], str], where: str) -> str:
    """text with every block of ``name`` replaced by render(argument).

    Raises InvalidInput naming ``where`` when a begin marker has no end marker (or the
    reverse): a half-written block would otherwise swallow or keep stale text silently."""
    begins = len(re.findall(rf"^<!-- {re.escape(name)}:begin", text, re.MULTILINE))
    ends = len(re.findall(rf"^<!-- {re.escape(name)}:end -->", text, re.MULTILINE))
    found = len(_pattern(name).findall(text))
    if not begins == ends == found:
        raise InvalidInput(f"{where}: unbalanced <!-- {name}:begin --> / <!-- {name}:end --> "
                           f"markers ({begins} begin, {ends} end)")

    def one(match: re.Match) -> str:
        argument = match["argument"] or ""
        block = render(argument)
        if block and not block.endswith("\n"):
            block += "\n"
        begin, end = markers(name, argument)
        return begin + "\n" + block + end

    return _pattern(name).sub(one, text)


def splice(text: str, name: str, block: str, where: str) -> str:
    """text with the one block of ``name`` replaced by block; InvalidInput naming ``where``
    unless there is exactly one."""
    count = len(blocks(text, name))
    if count != 1:
        begin, end = markers(name)
        raise InvalidInput(f"{where}: expected one {begin} ... {end} block, found {count}")
    return replace_blocks(text, name, lambda _: block, where)

"""What a figure kind returns: plans for the files it will draw, or a reason to skip."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable


@dataclass
class FigurePlan:
    """One figure file (PNG + PDF) a kind will draw from the results."""

    kind: str                 # figure kind, e.g. "slowdown vs threshold"
    stem: str                 # file name without extension, e.g. "slowdown_vs_threshold"
    summary: str              # one line: what the figure shows
    draw: Callable            # () -> matplotlib Figure


@dataclass
class Skipped:
    """A figure kind the results do not support, and why."""

    kind: str
    reason: str

"""What a figure kind returns: plans for the files it will draw, or a reason to skip."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from analysis import style


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


def slowdown_bar(ax, x, stat, width, colour):
    """A slowdown bar drawn from isolation (1.0) to the mean, min-max error bars (clipped at 0:
    a mean of equal repetitions may round a hair outside them)."""
    ax.bar(x, stat.mean - 1.0, width=width, bottom=1.0, color=colour,
           yerr=np.maximum(0.0, np.array([[stat.mean - stat.min], [stat.max - stat.mean]])),
           error_kw={"elinewidth": 0.8, "capsize": 1.5, "ecolor": "0.2"})

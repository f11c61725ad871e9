"""Shared plotting style: labels with units, number formats, colours, saving PNG + PDF."""

from __future__ import annotations

import math
import re
import textwrap
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (the backend must be chosen first)
from matplotlib.ticker import FixedLocator, FuncFormatter, NullLocator  # noqa: E402

DPI = 150
MAX_LINEAR_TICKS = 12
TITLE_CHARS_PER_IN = 11     # wrapping widths for the 10.5 pt title and 7.5 pt note
NOTE_CHARS_PER_IN = 16

SLOWDOWN_LABEL = "slowdown (× isolation)"
AXIS_LABELS = {
    "threshold_pct": "threshold (% of reference bandwidth)",
    "sampling_period_us": "sampling period (µs)",
    "regulation_period_us": "regulation period (µs)",
}
ISOLATION_STYLE = {"color": "0.35", "linestyle": "--", "linewidth": 1.0, "zorder": 1}
ISOLATION_LABEL = "isolation (1.0)"
# The unregulated co-run (the same nodes with policy none: what regulation protects from) and
# the user's RT slowdown target (rosguard plot --rt-slowdown-max, or tune.json).
UNREGULATED_STYLE = {"color": "firebrick", "linestyle": (0, (6, 3)), "linewidth": 1.3,
                     "zorder": 1.5}
UNREGULATED_LABEL = "unregulated co-run"
TARGET_STYLE = {"color": "black", "linestyle": ":", "linewidth": 1.5, "zorder": 1.6}


def target_label(value: float) -> str:
    """Legend words of the RT slowdown target line."""
    return f"target: RT slowdown ≤ {value:g}"

# Min / median / max markers as in the paper: ▽ × △.
MIN_MARKER = {"marker": "v", "markerfacecolor": "none", "linestyle": "none"}
MEDIAN_MARKER = {"marker": "x", "linestyle": "none"}
MAX_MARKER = {"marker": "^", "markerfacecolor": "none", "linestyle": "none"}

SAMPLING_COLOURS = {"self": "tab:blue", "external": "tab:orange"}
SERIES_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple",
                  "tab:brown", "tab:pink", "tab:olive", "tab:cyan", "tab:gray")
SERIES_MARKERS = ("o", "s", "D", "^", "v", "P", "X", "h", "<", ">")

ERRORBAR_NOTE = "markers: mean over repetitions; error bars: min–max over repetitions"


def colour(i: int) -> str:
    """The i-th series colour (cycled)."""
    return SERIES_COLOURS[i % len(SERIES_COLOURS)]


def marker(i: int) -> str:
    """The i-th series marker (cycled)."""
    return SERIES_MARKERS[i % len(SERIES_MARKERS)]


def number(value) -> str:
    """20.0 -> '20', 12.5 -> '12.5', None/NaN -> '-'."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    if isinstance(value, float) and value.is_integer():
        return str(int(value))
    return f"{value:g}" if isinstance(value, float) else str(value)


def period(us) -> str:
    """A period in µs as a reader writes it: 500 -> '500 µs', 5000 -> '5 ms'."""
    if us is None or (isinstance(us, float) and math.isnan(us)):
        return "-"
    if us >= 1000 and us % 100 == 0:
        return f"{number(us / 1000.0)} ms"
    return f"{number(float(us))} µs"


def period_axis(ax, values) -> None:
    """Log-scale x axis with a plain tick at every value that occurs."""
    ticks = sorted(set(values))
    ax.set_xscale("log")
    ax.xaxis.set_major_locator(FixedLocator(ticks))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: number(float(v))))
    ax.xaxis.set_minor_locator(NullLocator())
    lo, hi = ticks[0], ticks[-1]
    ax.set_xlim(lo / 1.4, hi * 1.4)
    if len(ticks) > 6:
        ax.tick_params(axis="x", labelrotation=45)


def linear_axis(ax, values) -> None:
    """Linear x axis with a tick at every value that occurs (automatic ticks beyond 12)."""
    ticks = sorted(set(values))
    if len(ticks) <= MAX_LINEAR_TICKS:
        ax.xaxis.set_major_locator(FixedLocator(ticks))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: number(float(v))))
    span = (ticks[-1] - ticks[0]) or 1.0
    ax.set_xlim(ticks[0] - 0.06 * span, ticks[-1] + 0.06 * span)


def isolation_line(ax) -> None:
    """Dashed horizontal line at slowdown 1.0 (isolation)."""
    ax.axhline(1.0, label=ISOLATION_LABEL, **ISOLATION_STYLE)


def new_figure(nrows: int, ncols: int, width: float, row_height: float, **kw):
    """A figure with a grid of axes (always a 2-D array) and room for a title."""
    fig, axes = plt.subplots(nrows, ncols, figsize=(width, row_height * nrows + 0.8),
                             squeeze=False, **kw)
    return fig, axes


def distribution_markers(ax, x, values, colour) -> None:
    """▽ min, × median, △ max of values at x, joined by a thin vertical line."""
    lo, med, hi = float(np.min(values)), float(np.median(values)), float(np.max(values))
    ax.plot([x, x], [lo, hi], color=colour, linewidth=0.8, alpha=0.5)
    ax.plot([x], [lo], color=colour, markersize=7, **MIN_MARKER)
    ax.plot([x], [med], color=colour, markersize=7, **MEDIAN_MARKER)
    ax.plot([x], [hi], color=colour, markersize=7, **MAX_MARKER)


def distribution_legend_proxies(ax) -> None:
    """Legend entries (no data) explaining the ▽ × △ markers."""
    for name, kw in (("min", MIN_MARKER), ("median", MEDIAN_MARKER),
                     ("max", MAX_MARKER)):
        ax.plot([], [], color="0.3", markersize=7, label=name, **kw)


def wrap(text: str, width: int) -> str:
    """Wraps at list separators (', ', '; ', ' — ') so '30 %' or '5 ms' never split;
    a single part longer than the width is wrapped at spaces."""
    lines = []
    for paragraph in text.split("\n"):
        line = ""
        for part in re.split(r"(?<=, )|(?<=; )|(?<= — )", paragraph):
            if line and len(line) + len(part.rstrip()) > width:
                lines.append(line.rstrip())
                line = ""
            line += part
        lines.extend(textwrap.wrap(line.rstrip(), width) or [""])
    return "\n".join(lines)


def finish(fig, title: str, note: str | None = None, right: float = 1.0) -> None:
    """Suptitle on top, an optional note at the bottom (both wrapped to the figure width),
    then a tight layout left of ``right``."""
    width = fig.get_figwidth()
    fig.suptitle(wrap(title, int(width * TITLE_CHARS_PER_IN)), fontsize=10.5)
    bottom = 0.0
    if note:
        note = wrap(note, int(width * NOTE_CHARS_PER_IN))
        fig.text(0.01, 0.008, note, fontsize=7.5, color="0.3", ha="left", va="bottom")
        bottom = (0.1 + 0.14 * (note.count("\n") + 1)) / fig.get_figheight()
    # tight_layout leaves room for the suptitle itself (matplotlib >= 3.3).
    fig.tight_layout(rect=(0, bottom, right, 1.0))


def save(fig, out_dir: Path, stem: str) -> list:
    """Writes stem.png and stem.pdf into out_dir and closes the figure; returns the paths."""
    paths = [out_dir / f"{stem}.png", out_dir / f"{stem}.pdf"]
    fig.savefig(paths[0], dpi=DPI)
    fig.savefig(paths[1])
    plt.close(fig)
    return paths

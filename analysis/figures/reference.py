"""What slowdown figures draw besides their series: the unregulated co-run and the target.

* The unregulated co-run: the same nodes with regulation off (policy none), which the runner
  measures once per co-run and writes into every row (``rt_unregulated_slowdown``,
  ``nrt_unregulated_slowdown``; a policy-none point carries its own slowdowns). Figures draw
  it as a dashed line (``style.UNREGULATED_STYLE``) labelled "unregulated co-run": what the RT
  node would suffer without regulation, and what the nRT node would get. Folders without the
  columns (older runs, ``rosguard run --no-unregulated``) simply have no such line; points.csv
  has them for the first RT and nRT node only, so other nodes' panels have none either.
* The target: an RT slowdown bound (``Results.rt_slowdown_max``: ``rosguard plot
  --rt-slowdown-max X`` or tune.json), drawn on every RT slowdown axis as a dotted line.
"""

from __future__ import annotations

import re

from analysis import style

_RT_SLOWDOWN = re.compile(r"^rt\d*_slowdown$")

# The first nodes' slowdowns: a folder with an unregulated co-run has one for them.
UNREGULATED_METRIC = ("rt_slowdown", "nrt_slowdown")


_NODE_SLOWDOWN = re.compile(r"^(n?rt\d*)_slowdown$")


def unregulated(points, metric: str) -> list:
    """The distinct unregulated co-run slowdowns (means over repetitions) behind the points'
    ``metric`` (a node's slowdown: "rt_slowdown", "nrt2_slowdown", ...), ascending; [] when none
    was measured."""
    node = _NODE_SLOWDOWN.match(metric)
    if node is None:
        return []
    column = f"{node.group(1)}_unregulated_slowdown"
    # The regulated points carry the co-run the runner measured (one value per co-run); the
    # policy-none points carry their own runs, each a little different on hw: they stand in,
    # as their mean, only where no regulated point says.
    regulated = [p.stat(column) for p in points if p.config.get("policy") != "none"]
    own = [p.stat(column) for p in points if p.config.get("policy") == "none"]
    values: list = []
    for s in regulated:
        if s and not any(abs(s.mean - v) <= 1e-9 * max(1.0, abs(v)) for v in values):
            values.append(s.mean)
    if not values and any(own):
        values.append(sum(s.mean for s in own if s) / sum(1 for s in own if s))
    return sorted(values)


def draw_unregulated(ax, points, metric: str, span=(0.0, 1.0)) -> list:
    """Dashed horizontal line(s) at the unregulated co-run slowdown over the axes fraction
    ``span``; returns the values drawn."""
    values = unregulated(points, metric)
    for v in values:
        ax.axhline(v, *span, label=style.UNREGULATED_LABEL, **style.UNREGULATED_STYLE)
    return values


def unregulated_segment(ax, x0: float, x1: float, value: float) -> None:
    """The unregulated co-run as a dashed segment from x0 to x1 (data coordinates): a
    reference for one cluster of bars."""
    ax.hlines(value, x0, x1, label=style.UNREGULATED_LABEL, **style.UNREGULATED_STYLE)


def target(results, metric: str):
    """The target bound of ``metric`` (an RT node's slowdown: the bound holds for every RT
    node), or None."""
    return results.rt_slowdown_max if target_applies(metric) else None


def target_applies(metric: str) -> bool:
    """True for an RT node's slowdown column (``rt_slowdown``, ``rt1_slowdown``, ...)."""
    return bool(_RT_SLOWDOWN.match(metric))


def draw_target(ax, value, vertical: bool = False) -> None:
    """The RT slowdown target as a dotted line (vertical: on an RT slowdown x axis)."""
    if value is None:
        return
    draw = ax.axvline if vertical else ax.axhline
    draw(value, label=style.target_label(value), **style.TARGET_STYLE)


def note(points, results) -> str:
    """Words for a figure's note on the references it draws ('' when none)."""
    words = []
    if any(unregulated(points, m) for m in UNREGULATED_METRIC):
        words.append("red dashed: the unregulated co-run (the same nodes with policy none, "
                     "measured once per co-run)")
    if results.rt_slowdown_max is not None:
        words.append(f"dotted: the RT slowdown target {results.rt_slowdown_max:g}")
    return "; ".join(words)

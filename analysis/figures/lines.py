"""Line figures: slowdowns (and the sampling cost) against one swept parameter.

Every line figure has one row of panels per group of points (e.g. per workload pair) and
one line per series (e.g. interval vs monolithic). Markers are means over repetitions,
error bars span min-max over repetitions, and the grey dashed line is isolation (slowdown 1.0).
Slowdown panels also draw the unregulated co-run of their points (red dashed, "unregulated
co-run": the same nodes with policy none, measured once per workload pair) and, on RT panels,
the user's target (dotted; ``rosguard plot --rt-slowdown-max`` or tune.json): see
analysis/figures/reference.py.
A kind applies when, with everything else fixed, its x parameter takes at least two values.

Kinds (paper experiment in brackets):

Slowdown figures have a panel per node (``analysis.nodes``): the RT node(s), then every nRT
node, each titled with its name ("nRT1 disparity" where there are several).

* slowdown vs threshold [4, 5, 8]: RT and nRT slowdown vs threshold_pct; lines per policy
  (interval vs monolithic), sampling mode and periods when they vary.
* slowdown vs sampling period [5]: RT and nRT slowdown vs sampling_period_us (log axis);
  lines per threshold. A regulation period that moves with the sampling period
  (regulation = 5 x sampling) is allowed and stated in the title.
* slowdown vs regulation period [6]: RT and nRT slowdown vs regulation_period_us at a fixed
  sampling period; lines per threshold / policy / sampling mode.
* sampling overhead vs sampling period [2]: points without an RT node (nRT alone), whose
  nRT slowdown is the cost of sampling; lines per sampling mode (self vs external), and the
  per-sample cost (samples of kind ``sampling_overhead``) as min / median / max.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from typing import Callable

import numpy as np

from analysis import style
from analysis.configs import (as_config, column_words, describe, distinct, finite, group_by,
                              held_fixed, title, varying)
from analysis.figures import reference
from analysis.figures.base import FigurePlan
from analysis.figures.grid import grid_applies
from analysis.nodes import nodes_of
from analysis.style import number

MAX_GROUPS_WITH_GRID = 6   # more rows than this on grid data: the RT x nRT grid shows them
GROUPS_PER_FILE = 4        # panel rows per file; more groups are split over numbered files
LEGEND_WIDTH_IN = 2.3

@dataclass(frozen=True)
class SlowdownPanel:
    """Mean slowdown of one node with min-max error bars, one line per series."""

    node: str            # the node's label: "RT mser", "nRT1 disparity"
    metric: str          # its slowdown column: "rt_slowdown", "nrt1_slowdown"
    heading: str

    def available(self, points, results) -> bool:
        """True when some point has this slowdown."""
        return any(p.stat(self.metric) for p in points)

    def draw(self, ax, series, results, x: str) -> None:
        """Draws every series of one group, the group's unregulated co-run and the target."""
        for index, label, points in series:
            pts = sorted((p for p in points if p.stat(self.metric) and finite(p.config[x])),
                         key=lambda p: p.config[x])
            if not pts:
                continue
            stats = [p.stat(self.metric) for p in pts]
            mean = np.array([s.mean for s in stats])
            # The mean of equal repetitions can round a last bit past their min or max: clip.
            err = [np.maximum(0.0, mean - [s.min for s in stats]),
                   np.maximum(0.0, np.array([s.max for s in stats]) - mean)]
            ax.errorbar([p.config[x] for p in pts], mean, yerr=err, color=style.colour(index),
                        marker=style.marker(index), markersize=5, linewidth=1.4, capsize=3,
                        label=label)
        style.isolation_line(ax)
        reference.draw_unregulated(ax, [p for _, _, pts in series for p in pts], self.metric)
        reference.draw_target(ax, reference.target(results, self.metric))
        ax.set_ylabel(f"{self.node} {style.SLOWDOWN_LABEL}")


@dataclass(frozen=True)
class SamplesPanel:
    """Min / median / max (▽ × △) of one sample kind per x value, one colour per series."""

    kind: str
    ylabel: str
    heading: str

    def available(self, points, results) -> bool:
        """True when some point has samples of this kind."""
        return any(results.samples_of(p.id, self.kind).size for p in points)

    def draw(self, ax, series, results, x: str) -> None:
        """Draws the distribution markers of every series of one group."""
        for index, _label, points in series:
            for xv in distinct(points, x):
                values = np.concatenate([results.samples_of(p.id, self.kind)
                                         for p in points if p.config[x] == xv])
                if values.size:
                    style.distribution_markers(ax, xv, values, style.colour(index))
        style.distribution_legend_proxies(ax)
        ax.set_ylabel(self.ylabel)
        ax.set_ylim(bottom=0)


@dataclass(frozen=True)
class Layout:
    """How a line kind splits the configuration columns for one folder."""

    series_cols: list
    series_keys: list
    group_cols: list
    tied: list
    fixed: dict
    panels: list


@dataclass(frozen=True)
class LineKind:
    """A figure kind drawing panels against one swept parameter x."""

    name: str
    stem: str
    what: str
    x: str
    series_candidates: tuple
    select: Callable
    panels: Callable     # Results -> the panels it could draw
    no_points_reason: str
    no_sweep_reason: str
    tied_candidates: tuple = ()
    log_x: bool = False

    def plan(self, results):
        """FigurePlans for this folder, or the reason the kind does not apply."""
        points = [p for p in results.points if self.select(p)]
        if not points:
            return self.no_points_reason
        panels = [pl for pl in self.panels(results) if pl.available(points, results)]
        if not panels or self.x not in results.config_columns:
            return self.no_points_reason
        lay, groups = self._layout(results, points, panels)
        if not groups:
            return self.no_sweep_reason
        if len(groups) > MAX_GROUPS_WITH_GRID and grid_applies(points):
            return (f"{len(groups)} groups of "
                    f"{', '.join(column_words(c) for c in lay.group_cols)} would be unreadable "
                    "as line panels; the RT x nRT grid figures show these points")
        chunks = [groups[i:i + GROUPS_PER_FILE] for i in range(0, len(groups), GROUPS_PER_FILE)]
        plans = []
        for i, chunk in enumerate(chunks):
            stem = self.stem if len(chunks) == 1 else f"{self.stem}_{i + 1}"
            summary = self._summary(lay, chunk, i, len(chunks))
            plans.append(FigurePlan(self.name, stem, summary,
                                    partial(self._draw, results, lay, chunk)))
        return plans

    def _layout(self, results, points, panels):
        config = results.config_columns
        tied = [c for c in self.tied_candidates
                if c in config and len(distinct(points, c)) > 1 and _function_of(points, self.x, c)]
        series_cols = varying(points, [c for c in self.series_candidates
                                       if c in config and c not in tied and c != self.x])
        rest = [c for c in config if c not in (self.x, *series_cols, *tied)]
        group_cols = varying(points, rest)
        groups = [(key, pts) for key, pts in group_by(points, group_cols).items()
                  if _sweeps(pts, series_cols, self.x)]
        lay = Layout(series_cols, list(group_by(points, series_cols)), group_cols, tied,
                     held_fixed(points, rest), panels)
        return lay, groups

    def _summary(self, lay, chunk, index, count) -> str:
        text = self.what
        if lay.series_cols:
            text += "; lines per " + ", ".join(column_words(c) for c in lay.series_cols)
        if lay.group_cols:
            text += (f"; {len(chunk)} row(s), one per "
                     + ", ".join(column_words(c) for c in lay.group_cols))
        if count > 1:
            text += f" (part {index + 1} of {count})"
        return text

    def _draw(self, results, lay, chunk):
        ncols = len(lay.panels)
        width = 4.8 * ncols + LEGEND_WIDTH_IN
        fig, axes = style.new_figure(len(chunk), ncols, width=width, row_height=3.3)
        handles: dict = {}
        for r, (key, points) in enumerate(chunk):
            row_words = describe(as_config(lay.group_cols, key))
            series = [(lay.series_keys.index(k), self._series_label(lay, k), pts)
                      for k, pts in group_by(points, lay.series_cols).items()]
            for c, panel in enumerate(lay.panels):
                ax = axes[r][c]
                panel.draw(ax, series, results, self.x)
                self._x_axis(ax, distinct(points, self.x))
                ax.set_title(panel.heading + (f"\n{row_words}" if row_words else ""), fontsize=9)
                ax.grid(True, alpha=0.3)
                for h, label in zip(*ax.get_legend_handles_labels()):
                    handles.setdefault(label, h)
        right = 1.0 - LEGEND_WIDTH_IN / width
        fig.legend(list(handles.values()), list(handles.keys()), loc="center left",
                   bbox_to_anchor=(right, 0.5), fontsize=8, frameon=False)
        style.finish(fig, self._title(results, lay), self._note(results, lay), right=right)
        return fig

    def _x_axis(self, ax, values) -> None:
        values = [v for v in values if finite(v)]
        if self.log_x:
            style.period_axis(ax, values)
        else:
            style.linear_axis(ax, values)
        ax.set_xlabel(style.AXIS_LABELS[self.x])

    def _series_label(self, lay, key) -> str:
        if lay.series_cols:
            return describe(as_config(lay.series_cols, key), short=True)
        policy = lay.fixed.get("policy")
        return str(policy) if policy else "mean"

    def _title(self, results, lay) -> str:
        head = self.what
        for c in lay.tied:
            head += f" ({_tied_words(c, self.x, results.points)})"
        return title(head, lay.fixed, results)

    def _note(self, results, lay) -> str:
        note = style.ERRORBAR_NOTE.replace("repetitions", f"{results.repetitions} repetitions", 1)
        if any(isinstance(p, SamplesPanel) for p in lay.panels):
            note += "; ▽ × △: min / median / max of the samples"
        if any(isinstance(p, SlowdownPanel) for p in lay.panels):
            refs = reference.note([p for p in results.points if self.select(p)], results)
            note += f"; {refs}" if refs else ""
        return note


def _function_of(points, x: str, column: str) -> bool:
    """True when each value of x comes with a single value of column."""
    seen: dict = {}
    return all(seen.setdefault(p.config[x], p.config[column]) == p.config[column]
               for p in points)


def _sweeps(points, series_cols, x: str) -> bool:
    """True when some series of these points has at least two x values."""
    return any(len([v for v in distinct(pts, x) if finite(v)]) >= 2
               for pts in group_by(points, series_cols).values())


def _tied_words(column: str, x: str, points) -> str:
    pairs = {p.config[x]: p.config[column] for p in points}
    ratios = {round(c / xv, 6) for xv, c in pairs.items() if finite(xv) and finite(c) and xv}
    if len(ratios) == 1:
        return f"{column_words(column)} = {number(ratios.pop())} × {column_words(x)}"
    listed = ", ".join(f"{style.period(xv)}→{style.period(c)}" for xv, c in sorted(pairs.items()))
    return f"{column_words(column)} moves with {column_words(x)}: {listed}"


def node_panels(results, role: str | None = None, heading: str = "{}") -> list:
    """A slowdown panel per node of the folder (of one role), headed with its label."""
    return [SlowdownPanel(n.label, n.metric, heading.format(n.label))
            for n in nodes_of(results, role)]


SLOWDOWN_VS_THRESHOLD = LineKind(
    name="slowdown vs threshold",
    stem="slowdown_vs_threshold",
    what="RT and nRT slowdown vs bandwidth threshold",
    x="threshold_pct",
    series_candidates=("policy", "sampling", "sampling_period_us", "regulation_period_us"),
    select=lambda p: p.has_rt,
    panels=node_panels,
    no_points_reason="no points with an RT node and slowdowns",
    no_sweep_reason="no threshold sweep (threshold_pct never varies with the rest fixed)",
)

SLOWDOWN_VS_SAMPLING = LineKind(
    name="slowdown vs sampling period",
    stem="slowdown_vs_sampling_period",
    what="RT and nRT slowdown vs sampling period",
    x="sampling_period_us",
    series_candidates=("threshold_pct", "policy", "sampling", "regulation_period_us"),
    tied_candidates=("regulation_period_us",),
    select=lambda p: p.has_rt,
    panels=node_panels,
    log_x=True,
    no_points_reason="no points with an RT node and slowdowns",
    no_sweep_reason="no sampling-period sweep with an RT node "
                    "(sampling_period_us never varies with the rest fixed)",
)

SLOWDOWN_VS_REGULATION = LineKind(
    name="slowdown vs regulation period",
    stem="slowdown_vs_regulation_period",
    what="RT and nRT slowdown vs regulation period",
    x="regulation_period_us",
    series_candidates=("threshold_pct", "policy", "sampling", "sampling_period_us"),
    select=lambda p: p.has_rt,
    panels=node_panels,
    no_points_reason="no points with an RT node and slowdowns",
    no_sweep_reason="no regulation-period sweep at a fixed sampling period",
)

SAMPLING_OVERHEAD = LineKind(
    name="sampling overhead vs sampling period",
    stem="sampling_overhead_vs_sampling_period",
    what="Sampling overhead of the nRT node alone vs sampling period",
    x="sampling_period_us",
    series_candidates=("sampling", "policy", "threshold_pct"),
    tied_candidates=("regulation_period_us",),
    select=lambda p: p.has_nrt and not p.has_rt,
    panels=lambda results: [
        *node_panels(results, "nrt", "{} slowdown (cost of sampling)"),
        SamplesPanel("sampling_overhead", "sampling overhead per sample (µs)",
                     "sampling overhead per sample")],
    log_x=True,
    no_points_reason="no nRT-alone points (nodes.rt empty) with an nRT slowdown",
    no_sweep_reason="no sampling-period sweep of the nRT node alone",
)

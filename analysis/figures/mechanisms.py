"""Mechanism comparison (paper experiment 8, Fig. memcore_comp): regulation mechanisms side by
side at the same thresholds.

A mechanism is a (policy, sampling) combination as the points name it (ROSGuard's interval
policy with self- or external sampling, MemGuard, MemPol, ... whatever the policy and
sampling columns hold). One file per RT workload (and per value of any other configuration
column that is neither a workload nor a regulation setting); in it a row of panels per node,
RT and nRT slowdown (every nRT node of the folder, titled with its name: ``analysis.nodes``),
and a column per threshold (or budget: every varying regulation level). Each
panel groups bars by nRT workload, one bar per series (the mechanism, plus the periods where
they vary), rising from isolation (1.0) to the mean over repetitions with min-max error bars.
Over each group a red dashed segment marks the unregulated co-run of the pair, and RT panels
carry the user's target (analysis/figures/reference.py).

Applies when the regulated co-run points hold at least two mechanisms.
"""

from __future__ import annotations

from functools import partial

from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from analysis import style
from analysis.configs import (as_config, column_words, describe, distinct, group_by,
                              held_fixed, keys_in_order, slug, title, varying)
from analysis.figures import reference
from analysis.figures.base import FigurePlan, slowdown_bar
from analysis.nodes import nodes_of

KIND = "mechanism comparison"
STEM = "mechanisms"
MECHANISM = ("policy", "sampling")
SERIES_COLUMNS = ("policy", "sampling", "sampling_period_us", "regulation_period_us", "scope")
X = "nrt_workload"
LEGEND_WIDTH_IN = 2.5


def level_columns(results) -> list:
    """The regulation levels a comparison is made at: the threshold, and budgets."""
    return [c for c in results.config_columns
            if c == "threshold_pct" or "budget" in c
            or c in ("param:regulation.threshold_pct",)]


def plan(results):
    """One FigurePlan per RT workload (and other file-level value), or a skip reason."""
    points = [p for p in results.points
              if p.has_rt and p.has_nrt and p.config.get("policy") != "none"
              and (p.stat("rt_slowdown") or p.stat("nrt_slowdown"))]
    mechanisms = keys_in_order(points, MECHANISM)
    if len(mechanisms) < 2:
        found = ", ".join(describe(as_config(MECHANISM, k), short=True) for k in mechanisms)
        return ("fewer than two mechanisms (policy, sampling) among the regulated co-run "
                f"points{' (only ' + found + ')' if found else ''}: nothing to compare")
    config = results.config_columns
    series_cols = varying(points, [c for c in SERIES_COLUMNS if c in config])
    levels = varying(points, [c for c in level_columns(results) if c not in series_cols])
    rest = [c for c in config if c not in (X, *series_cols, *levels)]
    file_cols = varying(points, rest)
    fixed = held_fixed(points, rest)
    series_keys = keys_in_order(points, series_cols)
    plans = []
    for key, pts in group_by(points, file_cols).items():
        file_config = as_config(file_cols, key)
        stem = f"{STEM}_{slug(file_config)}" if file_cols else STEM
        words = describe(file_config)
        summary = (f"RT and nRT slowdown per nRT workload, {len(series_keys)} series "
                   f"({', '.join(_label(series_cols, k) for k in series_keys)})"
                   f"{' per ' + ', '.join(column_words(c) for c in levels) if levels else ''}"
                   f"{', ' + words if words else ''}")
        plans.append(FigurePlan(KIND, stem, summary,
                                partial(_draw, results, pts, series_cols, series_keys, levels,
                                        {**fixed, **file_config})))
    return plans


def _label(series_cols, key) -> str:
    return describe(as_config(series_cols, key), short=True)


def _draw(results, points, series_cols, series_keys, levels, fixed):
    level_keys = [k for k in group_by(points, levels)] if levels else [()]
    nrts = distinct(points, X)
    panel_width = max(2.4, 0.32 * len(nrts) * len(series_keys) + 0.8)
    width = panel_width * len(level_keys) + 0.8 + LEGEND_WIDTH_IN
    rows = [(n.label if n.several else n.tag, n.metric) for n in nodes_of(results)]
    fig, axes = style.new_figure(len(rows), len(level_keys), width=width, row_height=2.9,
                                 sharey="row")
    by_level = group_by(points, levels) if levels else {(): points}
    target = reference.target(results, "rt_slowdown")
    for c, level in enumerate(level_keys):
        level_points = by_level.get(level, [])
        for r, (node, metric) in enumerate(rows):
            ax = axes[r][c]
            _draw_panel(ax, level_points, series_cols, series_keys, nrts, metric)
            reference.draw_target(ax, reference.target(results, metric))
            if r == 0:
                ax.set_title(describe(as_config(levels, level)) or "all points", fontsize=9)
            if c == 0:
                ax.set_ylabel(f"{node} {style.SLOWDOWN_LABEL}", fontsize=9)
    handles = [Patch(color=style.colour(i), label=_label(series_cols, k))
               for i, k in enumerate(series_keys)]
    handles.append(Line2D([], [], label=style.ISOLATION_LABEL, **style.ISOLATION_STYLE))
    if any(reference.unregulated(points, m) for _, m in rows):
        handles.append(Line2D([], [], label=style.UNREGULATED_LABEL,
                              **style.UNREGULATED_STYLE))
    if target is not None:
        handles.append(Line2D([], [], label=style.target_label(target), **style.TARGET_STYLE))
    right = 1.0 - LEGEND_WIDTH_IN / width
    fig.legend(handles=handles, loc="center left", bbox_to_anchor=(right, 0.5), fontsize=8,
               frameon=False, title="mechanism", title_fontsize=8)
    note = (f"bars: mean slowdown over {results.repetitions} repetitions, drawn from "
            "isolation (1.0); error bars: min–max over repetitions; groups: the first nRT "
            "node's workload")
    refs = reference.note(points, results)
    note += f"; {refs}" if refs else ""
    style.finish(fig, title("Mechanism comparison: RT and nRT slowdowns", fixed, results),
                 note, right=right)
    return fig


def _draw_panel(ax, points, series_cols, series_keys, nrts, metric) -> None:
    """Bars per nRT workload (one per series) and the unregulated co-run over each group."""
    n = len(series_keys)
    width = 0.8 / n
    cells = group_by(points, [X])
    for g, nrt in enumerate(nrts):
        cell = cells.get((nrt,), [])
        by_series = group_by(cell, series_cols)
        for i, key in enumerate(series_keys):
            stats = [p.stat(metric) for p in by_series.get(key, []) if p.stat(metric)]
            if not stats:
                continue
            s = stats[0]
            x = g + (i - (n - 1) / 2) * width
            slowdown_bar(ax, x, s, width, style.colour(i))
        for value in reference.unregulated(cell, metric):
            reference.unregulated_segment(ax, g - 0.45, g + 0.45, value)
    ax.axhline(1.0, **style.ISOLATION_STYLE)
    ax.set_xticks(range(len(nrts)))
    ax.set_xticklabels([str(w) for w in nrts], fontsize=7.5, rotation=30, ha="right")
    ax.set_xlim(-0.6, len(nrts) - 0.4)
    ax.tick_params(axis="y", labelsize=8)
    ax.grid(True, axis="y", alpha=0.3)

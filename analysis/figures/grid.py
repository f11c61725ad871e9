"""RT x nRT grid (paper experiments 7 and 8).

One file per threshold (and per value of any other parameter that is neither a workload nor
part of the regulation configuration). Rows are RT workloads, columns the first nRT node's
workloads; each cell holds a cluster of bars per node, RT slowdown and nRT slowdown (with
several nRT nodes one cluster per nRT node, "nRT0", "nRT1", ..., named in the note), one bar per
configuration (policy, sampling mode, sampling / regulation period, e.g. "self 1 ms /
reg. 5 ms"). Bars rise from isolation (slowdown 1.0, dashed) to the mean over repetitions;
error bars span min-max over repetitions. All cells share the y axis. Over each cluster a red
dashed segment marks the unregulated co-run of the pair (policy none, measured once per pair),
and a dotted one over the RT cluster the user's RT slowdown target (analysis/figures/reference.py).
Without configuration columns the single bar is labelled "simulated" or "measured" after the
backend.

Applies when, for some RT workload, the nRT workload takes at least two values.
"""

from __future__ import annotations

from functools import partial

from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from analysis import style
from analysis.configs import (as_config, backend_words, describe, distinct, group_by,
                              held_fixed, keys_in_order, slug, title, varying)
from analysis.figures import reference
from analysis.figures.base import FigurePlan, slowdown_bar
from analysis.nodes import nodes_of

KIND = "RT x nRT grid"
STEM = "rt_nrt_grid"
CONFIGURATION_COLUMNS = ("policy", "sampling", "sampling_period_us", "regulation_period_us",
                         "scope")
WORKLOADS = ("rt_workload", "nrt_workload")
LEGEND_WIDTH_IN = 2.4
CELL_WIDTH_IN = 1.75
CELL_HEIGHT_IN = 1.9


def grid_applies(points) -> bool:
    """True when some RT workload runs against at least two nRT workloads."""
    by_rt: dict = {}
    for p in points:
        if p.has_rt and p.has_nrt:
            by_rt.setdefault(p.config["rt_workload"], set()).add(p.config["nrt_workload"])
    return any(len(nrts) >= 2 for nrts in by_rt.values())


def plan(results):
    """One FigurePlan per threshold (and other file-level parameter), or a skip reason."""
    points = [p for p in results.points
              if p.has_rt and p.has_nrt and (p.stat("rt_slowdown") or p.stat("nrt_slowdown"))]
    if not grid_applies(points):
        return "the nRT workload does not vary against an RT workload: no RT x nRT grid"
    config = results.config_columns
    conf_cols = varying(points, [c for c in CONFIGURATION_COLUMNS if c in config])
    rest = [c for c in config if c not in (*WORKLOADS, *conf_cols)]
    file_cols = varying(points, rest)
    fixed = held_fixed(points, rest)
    conf_keys = keys_in_order(points, conf_cols)
    plans = []
    for key, pts in group_by(points, file_cols).items():
        file_config = as_config(file_cols, key)
        stem = f"{STEM}_{slug(file_config)}" if file_cols else STEM
        words = describe(file_config)
        labels = ", ".join(_conf_label(conf_cols, k, results.backend) for k in conf_keys)
        summary = (f"RT and nRT slowdown per RT x nRT workload pair"
                   f"{', ' + words if words else ''}; bars per configuration "
                   f"({len(conf_keys)}: {labels})")
        draw = partial(_draw, results, pts, conf_cols, conf_keys, {**fixed, **file_config})
        plans.append(FigurePlan(KIND, stem, summary, draw))
    return plans


def _conf_label(conf_cols, key, backend) -> str:
    return describe(as_config(conf_cols, key), short=True) if conf_cols \
        else backend_words(backend)


def _draw(results, points, conf_cols, conf_keys, fixed):
    rts = distinct(points, "rt_workload")
    nrts = distinct(points, "nrt_workload")
    width = CELL_WIDTH_IN * len(nrts) * max(1.0, len(nodes_of(results)) / 2) + 1.0 \
        + LEGEND_WIDTH_IN
    fig, axes = style.new_figure(len(rts), len(nrts), width=width, row_height=CELL_HEIGHT_IN,
                                 sharey=True)
    cells = group_by(points, WORKLOADS)
    nodes = nodes_of(results)
    clusters = [(n.tag, n.metric) for n in nodes]
    first_nrt = next((n.tag for n in nodes if n.role == "nrt"), "nRT")
    extremes = [1.0]
    for r, rt in enumerate(rts):
        for c, nrt in enumerate(nrts):
            ax = axes[r][c]
            cell = cells.get((rt, nrt))
            if cell:
                extremes += _draw_cell(ax, cell, conf_cols, conf_keys, clusters,
                                       reference.target(results, "rt_slowdown"))
            else:
                ax.text(0.5, 0.5, "no data", transform=ax.transAxes, ha="center",
                        va="center", fontsize=8, color="0.5")
                ax.set_xticks([])
            if r == 0:
                ax.set_title(f"{first_nrt} {nrt}", fontsize=9)
            if c == 0:
                ax.set_ylabel(f"RT {rt}\nslowdown (×)", fontsize=9)
    lo, hi = min(extremes), max(extremes)
    axes[0][0].set_ylim(min(lo, 1.0) - 0.02 * (hi - lo), hi + 0.22 * (hi - lo or 1.0))
    handles = [Patch(color=style.colour(i), label=_conf_label(conf_cols, k, results.backend))
               for i, k in enumerate(conf_keys)]
    handles.append(Line2D([], [], label=style.ISOLATION_LABEL, **style.ISOLATION_STYLE))
    if any(reference.unregulated(points, m) for m in reference.UNREGULATED_METRIC):
        handles.append(Line2D([], [], label=style.UNREGULATED_LABEL,
                              **style.UNREGULATED_STYLE))
    if results.rt_slowdown_max is not None:
        handles.append(Line2D([], [], label=style.target_label(results.rt_slowdown_max),
                              **style.TARGET_STYLE))
    right = 1.0 - LEGEND_WIDTH_IN / width
    fig.legend(handles=handles, loc="center left", bbox_to_anchor=(right, 0.5), fontsize=8,
               frameon=False, title="configuration", title_fontsize=8)
    note = ("bars (value on top): mean slowdown over "
            f"{results.repetitions} repetitions, drawn from isolation (1.0); "
            "error bars: min–max over repetitions; rows: RT workload, columns: nRT workload")
    if any(n.several for n in nodes):
        note += (f" (of {first_nrt}); clusters: " + ", ".join(n.label for n in nodes))
    refs = reference.note(points, results)
    note += f"; {refs}" if refs else ""
    style.finish(fig, title("RT x nRT slowdowns", fixed, results), note, right=right)
    return fig


def _draw_cell(ax, cell, conf_cols, conf_keys, clusters, target=None) -> list:
    """A cluster of bars per node (``clusters``: [(tick label, slowdown column)]), one bar per
    configuration, each labelled with its
    value (the y axis is shared, so small RT slowdowns stay readable), the unregulated
    co-run over each cluster and the RT target over the RT one; returns the min and max
    slowdowns drawn."""
    by_conf = group_by(cell, conf_cols)
    n = len(conf_keys)
    width = 0.8 / n
    extremes = []
    for node, (_, metric) in enumerate(clusters):
        for i, key in enumerate(conf_keys):
            stats = [p.stat(metric) for p in by_conf.get(key, []) if p.stat(metric)]
            if not stats:
                continue
            s = stats[0]
            x = node + (i - (n - 1) / 2) * width
            slowdown_bar(ax, x, s, width, style.colour(i))
            ax.annotate(f"{s.mean:.2f}", (x, max(s.max, 1.0)), xytext=(0, 1.5),
                        textcoords="offset points", rotation=90, ha="center", va="bottom",
                        fontsize=5.5)
            extremes += [s.min, s.max]
        for value in reference.unregulated(cell, metric):
            reference.unregulated_segment(ax, node - 0.45, node + 0.45, value)
            extremes.append(value)
        if target is not None and reference.target_applies(metric):
            ax.hlines(target, node - 0.45, node + 0.45, label=style.target_label(target),
                      **style.TARGET_STYLE)
            extremes.append(target)
    ax.axhline(1.0, **style.ISOLATION_STYLE)
    ax.set_xticks(range(len(clusters)))
    ax.set_xticklabels([label for label, _ in clusters], fontsize=8)
    ax.set_xlim(-0.55, len(clusters) - 0.45)
    ax.tick_params(axis="y", labelsize=8)
    ax.grid(True, axis="y", alpha=0.3)
    return extremes

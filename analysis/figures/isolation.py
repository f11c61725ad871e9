"""Isolation figures per workload (the paper's Table 1).

Bars: the IPC and the Eq. 1 bandwidth (MB/s) of each workload run alone, unregulated, as the
run measured (or simulated) them: the ``rt_isolation_*`` / ``nrt_isolation_*`` columns. When
the manifest lists the workload's reference figures (``workloads.<name>.reference``, the
paper's Table 1 for the shipped workloads), they are drawn as black ticks beside the bars and
the error in % is written over each bar.

Applies when at least two workloads have isolation figures and no point is a co-run (an
isolation sweep such as ``scenarios/paper/table1.json``); co-run sweeps show their isolation
figures in summary.csv instead.
"""

from __future__ import annotations

import math
from functools import partial

import numpy as np

from analysis import style
from analysis.figures.base import FigurePlan

KIND = "isolation figures (Table 1)"
STEM = "isolation_table1"
PANELS = (("ipc", "IPC (instructions per cycle)", False),
          ("mbps", "bandwidth, Eq. 1 (MB/s)", True))


def isolation_figures(results) -> dict:
    """workload -> {"ipc": mean, "mbps": mean} from the isolation columns of every row."""
    acc: dict = {}
    for role in ("rt", "nrt"):
        for row in results.rows:
            name = row.get(f"{role}_workload")
            if not name:
                continue
            for metric in ("ipc", "mbps"):
                v = row.get(f"{role}_isolation_{metric}")
                if v is not None and math.isfinite(v):
                    acc.setdefault(name, {}).setdefault(metric, []).append(v)
    return {w: {m: float(np.mean(v)) for m, v in d.items()} for w, d in acc.items()}


def references(results) -> dict:
    """workload -> reference {"ipc", "mbps", "source"} from the manifest, where given."""
    out = {}
    for name, entry in (results.manifest.get("workloads") or {}).items():
        ref = entry.get("reference") if isinstance(entry, dict) else None
        if isinstance(ref, dict):
            out[name] = ref
    return out


def plan(results):
    """One FigurePlan, or the reason to skip."""
    if any(p.has_rt and p.has_nrt for p in results.points):
        return "co-run points: their isolation figures are in summary.csv"
    figures = isolation_figures(results)
    if len(figures) < 2:
        return "fewer than two workloads with isolation figures"
    refs = references(results)
    with_ref = sum(1 for w in figures if w in refs)
    summary = (f"IPC and Eq. 1 bandwidth of {len(figures)} workloads alone"
               + (f", next to the reference (Table 1) for {with_ref}" if with_ref else ""))
    return [FigurePlan(KIND, STEM, summary, partial(_draw, results, figures, refs))]


def error_pct(measured: float, reference) -> float:
    """Error of a measured figure against its reference, in % (NaN without a reference)."""
    if reference is None or not reference:
        return math.nan
    return 100.0 * (measured - reference) / reference


def _draw(results, figures, refs):
    names = list(figures)
    fig, axes = style.new_figure(1, 2, width=4.2 + 0.75 * len(names), row_height=3.6)
    x = np.arange(len(names))
    for ax, (metric, label, log) in zip(axes[0], PANELS):
        values = [figures[w].get(metric, math.nan) for w in names]
        ax.bar(x, values, width=0.6, color=style.colour(0), label=f"{results.backend}")
        ref = [refs.get(w, {}).get(metric) for w in names]
        if any(r is not None for r in ref):
            ax.scatter([i for i, r in enumerate(ref) if r is not None],
                       [r for r in ref if r is not None], marker="_", s=600, linewidths=2.5,
                       color="black", zorder=3, label="reference (Table 1)")
        for i, (v, r) in enumerate(zip(values, ref)):
            e = error_pct(v, r)
            if math.isfinite(e):
                text = f"{e:+.2f} %" if abs(e) < 1 else f"{e:+.1f} %"
                ax.annotate(text, (i, v), textcoords="offset points", xytext=(0, 4),
                            ha="center", fontsize=7)
        if log:
            ax.set_yscale("log")
        ax.margins(y=0.12)
        ax.set_xticks(x, names, rotation=30, ha="right")
        ax.set_ylabel(label)
        ax.grid(axis="y", alpha=0.3)
    axes[0][1].legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, frameon=False)
    style.finish(fig, f"Isolation figures per workload [{results.backend}, {results.platform}]",
                 "bars: mean over repetitions of the unregulated isolation run; labels: error "
                 "against the reference in %", right=0.86)
    return fig

"""Distributions per sampling period (paper experiments 1 and 3).

* activation delay vs sampling period [3]: time from publishing a threshold-exceeding sample
  to entering the throttle callback (samples of kind ``activation_delay``).
* PMC callback duration vs sampling period [1]: samples of kind ``pmc_callback``.

Both show, per sampling period and sampling mode (self vs external, side by side), the
minimum (▽), median (×) and maximum (△) of all samples, pooled over the points that share
that sampling period and mode (the title and note say what is held fixed and what is pooled).
They apply as soon as samples of their kind exist for one sampling period.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np
from matplotlib.lines import Line2D

from analysis import style
from analysis.configs import column_words, distinct, finite, held_fixed, title, varying
from analysis.figures.base import FigurePlan
from analysis.style import number

X = "sampling_period_us"
MODE = "sampling"
LEGEND_WIDTH_IN = 2.0
SIDE_BY_SIDE = 0.07   # relative x offset between sampling modes on the log axis


@dataclass(frozen=True)
class DistributionKind:
    """Min / median / max of one sample kind per sampling period, self vs external."""

    name: str
    stem: str
    sample_kind: str
    what: str
    ylabel: str

    def plan(self, results):
        """One FigurePlan, or the reason the kind does not apply."""
        points = [p for p in results.points
                  if results.samples_of(p.id, self.sample_kind).size and finite(p.config[X])]
        if not points:
            return f"no {self.sample_kind} samples in samples.csv"
        others = [c for c in results.config_columns if c not in (X, MODE)]
        pooled = varying(points, others)
        fixed = held_fixed(points, others)
        modes = distinct(points, MODE)
        periods = distinct(points, X)
        summary = (f"{self.what}: min / median / max at {len(periods)} sampling period(s), "
                   f"{' vs '.join(str(m) for m in modes)} sampling")
        if pooled:
            summary += f", pooled over {', '.join(column_words(c) for c in pooled)}"
        draw = partial(self._draw, results, points, pooled, fixed)
        return [FigurePlan(self.name, self.stem, summary, draw)]

    def _draw(self, results, points, pooled, fixed):
        width = 6.6 + LEGEND_WIDTH_IN
        fig, axes = style.new_figure(1, 1, width=width, row_height=3.8)
        ax = axes[0][0]
        modes = distinct(points, MODE)
        handles = []
        for i, mode in enumerate(modes):
            colour = style.SAMPLING_COLOURS.get(mode, style.colour(i + 2))
            factor = 1.0 + SIDE_BY_SIDE * (i - (len(modes) - 1) / 2)
            for sp in distinct(points, X):
                values = [results.samples_of(p.id, self.sample_kind) for p in points
                          if p.config[MODE] == mode and p.config[X] == sp]
                if values:
                    style.distribution_markers(ax, sp * factor, np.concatenate(values), colour)
            handles.append(Line2D([], [], color=colour, marker="s", linestyle="none",
                                  label=f"{mode}-sampling" if mode else "sampling"))
        style.distribution_legend_proxies(ax)
        proxies, labels = ax.get_legend_handles_labels()
        style.period_axis(ax, distinct(points, X))
        ax.set_xlabel(style.AXIS_LABELS[X])
        ax.set_ylabel(self.ylabel)
        ax.set_ylim(bottom=0)
        ax.grid(True, alpha=0.3)
        right = 1.0 - LEGEND_WIDTH_IN / width
        fig.legend(handles=handles + proxies, loc="center left", bbox_to_anchor=(right, 0.5),
                   fontsize=8, frameon=False)
        head = f"{self.what} (▽ min, × median, △ max) vs sampling period"
        style.finish(fig, title(head, fixed, results), self._note(results, points, pooled),
                     right=right)
        return fig

    def _note(self, results, points, pooled) -> str:
        note = (f"all {self.sample_kind} samples of {len(points)} point(s) x "
                f"{results.repetitions} repetition(s)")
        if pooled:
            note += "; pooled over " + "; ".join(
                f"{column_words(c)} {_values_words(c, distinct(points, c))}" for c in pooled)
        return note


def _values_words(column: str, values) -> str:
    """'5–30 %' for numbers (with the unit), 'a / b' for a few words, '(N values)' else."""
    if all(isinstance(v, float) for v in values):
        unit = " %" if column.endswith("_pct") else " µs" if column.endswith("_us") else ""
        return f"{number(min(values))}–{number(max(values))}{unit}"
    if len(values) <= 4:
        return " / ".join(str(v) for v in values)
    return f"({len(values)} values)"


ACTIVATION_DELAY = DistributionKind(
    name="activation delay vs sampling period",
    stem="activation_delay_vs_sampling_period",
    sample_kind="activation_delay",
    what="Activation delay",
    ylabel="activation delay (µs)",
)

PMC_CALLBACK = DistributionKind(
    name="PMC callback duration vs sampling period",
    stem="pmc_callback_vs_sampling_period",
    sample_kind="pmc_callback",
    what="PMC callback duration",
    ylabel="PMC callback duration (µs)",
)

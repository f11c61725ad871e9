"""Distributions per sampling period (paper experiments 1 and 3).

* activation delay vs sampling period [3]: time from publishing a threshold-exceeding sample
  to entering the throttle callback (samples of kind ``activation_delay``).
* PMC callback duration vs sampling period [1]: samples of kind ``pmc_callback``.

Both show, per sampling period and sampling mode (self vs external, side by side), the
minimum (▽), median (×) and maximum (△) of all samples, pooled over the points that share
that sampling period and mode (the title and note say what is held fixed and what is pooled).
They apply as soon as samples of their kind exist for one sampling period. With a single
sampling period a line of min / median / max says little: the figure is then a box per series
(sampling mode, and policy where it varies) of all its samples at that period: the box spans
the quartiles with the median inside, whiskers reach the last sample within 1.5 IQR, circles
are the samples beyond.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np
from matplotlib.lines import Line2D

from analysis import style
from analysis.configs import (as_config, column_words, describe, distinct, finite, group_by,
                              held_fixed, title, varying)
from analysis.figures.base import FigurePlan
from analysis.style import number

X = "sampling_period_us"
MODE = "sampling"
BOX_SERIES = ("policy", MODE)   # a box per value of these (MODE always) at one sampling period
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
        if len(periods) == 1:
            series_cols = [c for c in BOX_SERIES if c in pooled or c == MODE]
            pooled = [c for c in pooled if c not in series_cols]
            summary = (f"{self.what}: distribution (box) at sampling period "
                       f"{style.period(periods[0])}, a box per "
                       f"{', '.join(column_words(c) for c in series_cols)}")
            draw = partial(self._draw_boxes, results, points, series_cols, pooled,
                           held_fixed(points, [c for c in results.config_columns
                                               if c not in (X, *series_cols)]))
        else:
            summary = (f"{self.what}: min / median / max at {len(periods)} sampling "
                       f"period(s), {' vs '.join(str(m) for m in modes)} sampling")
            draw = partial(self._draw, results, points, pooled, fixed)
        if pooled:
            summary += f", pooled over {', '.join(column_words(c) for c in pooled)}"
        return [FigurePlan(self.name, self.stem, summary, draw)]

    def _draw_boxes(self, results, points, series_cols, pooled, fixed):
        """A box per series of every sample at the one sampling period."""
        groups = group_by(points, series_cols)
        legend_in = 3.2
        width = max(4.5, 1.3 * len(groups) + 2.0) + legend_in
        fig, axes = style.new_figure(1, 1, width=width, row_height=3.8)
        ax = axes[0][0]
        data, labels, colours = [], [], []
        for i, (key, pts) in enumerate(groups.items()):
            values = [results.samples_of(p.id, self.sample_kind) for p in pts]
            data.append(np.concatenate(values))
            config = as_config(series_cols, key)
            mode = config.get(MODE)
            labels.append(describe(config, short=True) if len(series_cols) > 1 else
                          (f"{mode}-sampling" if mode else "sampling"))
            colours.append(style.SAMPLING_COLOURS.get(mode, style.colour(i + 2))
                           if series_cols == [MODE] else style.colour(i))
        boxes = ax.boxplot(data, positions=range(len(data)), widths=0.5, patch_artist=True,
                           medianprops={"color": "black", "linewidth": 1.4},
                           flierprops={"marker": "o", "markersize": 3, "alpha": 0.6})
        for patch, colour in zip(boxes["boxes"], colours):
            patch.set_facecolor(colour)
            patch.set_alpha(0.55)
        ax.set_xticks(range(len(data)))
        ax.set_xticklabels(labels, fontsize=8)
        ax.set_ylabel(self.ylabel)
        ax.set_ylim(bottom=0)
        ax.grid(True, axis="y", alpha=0.3)
        handles = [Line2D([], [], color=c, marker="s", linestyle="none", markersize=8,
                          alpha=0.7, label=f"{label} ({len(d)} samples)")
                   for c, label, d in zip(colours, labels, data)]
        right = 1.0 - legend_in / width
        fig.legend(handles=handles, loc="center left", bbox_to_anchor=(right, 0.5),
                   fontsize=8, frameon=False)
        period = style.period(distinct(points, X)[0])
        head = f"{self.what} distribution at one sampling period ({period})"
        note = ("box: quartiles, line: median, whiskers: the last sample within 1.5 × IQR, "
                "circles: samples beyond; " + self._note(results, points, pooled))
        style.finish(fig, title(head, fixed, results), note, right=right)
        return fig

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

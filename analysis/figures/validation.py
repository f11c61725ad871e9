"""The validation figure: simulated vs measured slowdown per point (``make validate``).

Four panels: the RT node's slowdown, the nRT nodes' slowdown (every co-runner; sim on y, hw
on x, each with the identity line and the +-5 % / +-10 % bands around it; log axes where the
values span more than a factor LOG_SPAN), the excess slowdown
(slowdown - 1) of both on log axes, where the measured excess is at least the report's
minimum, with a +-20 % band, and the MAPE per number of co-runners k (RT, nRT over every
co-runner, the per-node nRT MAPEs' min-max as a bar, the goals as lines; the report's
``per_k``). Marker shape: the node (RT o, nRT ^); colour: the scenario.
Markers are means over repetitions, error bars min-max over repetitions on each side; the axis
limits follow the means, so the bar of an outlying repetition may run off the panel. Where a pair
has a prediction band (``band_low`` / ``band_high``: the sim model's band platforms, see
``analysis.validation``), it is a wide pale vertical bar on the sim point (non-negative lengths,
nothing where a bound is NaN; the limits do not follow it either).

Not a registry kind (``plot`` draws one results folder; this needs the hw and sim folders of
a whole suite): ``analysis.validation`` calls ``draw``.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.ticker import FuncFormatter

from analysis import style

NODE_MARKERS = {"rt": "o", "nrt": "^"}
NODE_NAMES = {"rt": "RT", "nrt": "nRT"}
BANDS = ((0.10, "0.92", "±10 %"), (0.05, "0.80", "±5 %"))   # widest first: drawn below
EXCESS_BAND = (0.20, "0.85", "±20 %")
LOG_SPAN = 3.0
DISTURBED_RATIO = 2.0
TITLE_CHARS = 48
BAND_STYLE = {"elinewidth": 5.0, "alpha": 0.3}


def draw(pairs, scenarios, summary: dict, excess_min: float, note: str, per_k=(),
         goals=None):
    """The figure. pairs: objects with .scenario, .node ('rt' | 'nrt'), .hw and .sim (Stat);
    scenarios: scenario names in legend order; summary: {'rt' | 'nrt': panel title suffix};
    per_k: the report's per-k rows; goals: {'rt' | 'nrt': MAPE bound in %}."""
    colours = {name: style.colour(i) for i, name in enumerate(scenarios)}
    fig, axes = style.new_figure(1, 4, width=20.0, row_height=5.2)
    _per_k_panel(axes[0][3], list(per_k), goals or {})
    for ax, node in zip(axes[0][:2], ("rt", "nrt")):
        _slowdown_panel(ax, [p for p in pairs if p.node == node], node, colours)
        ax.set_title(style.wrap(f"{NODE_NAMES[node]} node: {summary.get(node, '')}",
                                TITLE_CHARS), fontsize=9)
    _excess_panel(axes[0][2], pairs, colours, excess_min)
    axes[0][2].set_title(style.wrap(summary.get("excess", "excess slowdown"), TITLE_CHARS),
                         fontsize=9)
    handles = [axes[0][0].plot([], [], linestyle="none", marker="s", color=colours[s],
                               label=s)[0] for s in scenarios]
    handles += [axes[0][0].plot([], [], linestyle="none", marker=NODE_MARKERS[n], color="0.3",
                                markerfacecolor="none", label=f"{NODE_NAMES[n]} node")[0]
                for n in ("rt", "nrt")]
    if any(_has_band(p) for p in pairs):
        handles.append(axes[0][0].plot([], [], color="0.3", linewidth=BAND_STYLE["elinewidth"],
                                       alpha=BAND_STYLE["alpha"],
                                       label="sim prediction band")[0])
    fig.legend(handles=handles, loc="center right", fontsize=8, frameon=False)
    style.finish(fig, "Validation: simulated vs measured slowdown per point", note, right=0.86)
    return fig


def _finite(v) -> bool:
    return v is not None and math.isfinite(v)


def bar_lengths(centre, low, high) -> tuple:
    """(below, above): an error bar's lengths from its centre to low and to high, as
    matplotlib wants them: non-negative distances. 0 where the spread does not reach past the
    centre (a mean outside min..max: rounding of a mean of equal values, or a centre clipped to a
    log axis's floor) or where a bound is NaN / infinite."""
    below, above = centre - low, high - centre
    return (below if _finite(below) and below > 0 else 0.0,
            above if _finite(above) and above > 0 else 0.0)


def _has_band(p) -> bool:
    return _finite(getattr(p, "band_low", None)) or _finite(getattr(p, "band_high", None))


def band_of(p, shift=0.0, floor=None) -> tuple:
    """(low, high) of a pair's prediction band minus shift, each at least floor (a log axis's
    bottom); NaN where the pair has none."""
    bounds = []
    for v in (getattr(p, "band_low", math.nan), getattr(p, "band_high", math.nan)):
        v = v - shift if _finite(v) else math.nan
        bounds.append(max(v, floor) if floor is not None and _finite(v) else v)
    return tuple(bounds)


def _errorbars(ax, pts, colours, x_of, y_of, band_of_pair=band_of) -> int:
    """Draws each point with its min-max bars (and its prediction band, where it has one, as a
    wide pale bar: band_of_pair(p) -> (low, high) on the panel's scale); a point whose mean is
    not finite on either side has no place on the axes and is left out. Returns how many were
    drawn."""
    drawn = 0
    for p in pts:
        x, y = x_of(p.hw), y_of(p.sim)
        if not (_finite(x[0]) and _finite(y[0])):
            continue
        if _has_band(p):
            below, above = bar_lengths(y[0], *band_of_pair(p))
            if below or above:
                ax.errorbar([x[0]], [y[0]], yerr=[[below], [above]], linestyle="none",
                            marker="none", capsize=0, color=colours.get(p.scenario, "0.3"),
                            zorder=1.5, **BAND_STYLE)
        xerr, yerr = bar_lengths(*x), bar_lengths(*y)
        ax.errorbar([x[0]], [y[0]], xerr=[[xerr[0]], [xerr[1]]], yerr=[[yerr[0]], [yerr[1]]],
                    linestyle="none", marker=NODE_MARKERS[p.node], markersize=6,
                    markerfacecolor="none", color=colours.get(p.scenario, "0.3"),
                    elinewidth=0.7, capsize=2)
        drawn += 1
    return drawn


def _slowdown(stat) -> tuple:
    return stat.mean, stat.min, stat.max


def disturbed(p) -> bool:
    """A point whose hw repetitions disagree by more than DISTURBED_RATIO (max / min): one
    repetition disturbed by the host (seen on a busy 2-vCPU VM: an RT job 100 x its isolation
    time). It stays in the report's numbers; the figure's limits ignore it."""
    return p.hw.min > 0 and p.hw.max / p.hw.min > DISTURBED_RATIO


def _limits_note(ax, pts, lim, shift=0.0, y=0.02) -> None:
    """Says how many disturbed points lie outside the axes (values minus shift)."""
    out = sum(1 for p in pts if disturbed(p) and not (
        lim[0] <= p.hw.mean - shift <= lim[1] and lim[0] <= p.sim.mean - shift <= lim[1]))
    if out:
        ax.text(0.98, y, f"{out} point(s) with disturbed hw repetitions (max > "
                f"{DISTURBED_RATIO:g} x min) outside the axes", transform=ax.transAxes,
                ha="right", va="bottom", fontsize=7.5, color="0.4")


def _slowdown_panel(ax, pts, node, colours) -> None:
    # Limits from the means of the undisturbed points: one disturbed repetition must not
    # squeeze every other point into a corner; error bars may run off the panel.
    values = [v for p in pts if not disturbed(p) for v in (p.hw.mean, p.sim.mean)
              if _finite(v)]
    lo, hi = (min(values), max(values)) if values else (1.0, 1.0)
    log = lo > 0 and hi / lo > LOG_SPAN
    if log:
        lim = (lo / 1.2, hi * 1.2)
        x = np.geomspace(lim[0], lim[1], 50)
    else:
        pad = 0.06 * ((hi - lo) or 0.1)
        lim = (lo - pad, hi + pad)
        x = np.linspace(lim[0], lim[1], 50)
    for width, shade, label in BANDS:
        ax.fill_between(x, x * (1 - width), x * (1 + width), color=shade, linewidth=0,
                        label=f"{label} of measured", zorder=0)
    ax.plot(lim, lim, color="0.35", linestyle="--", linewidth=1.0, label="sim = hw", zorder=1)
    if not _errorbars(ax, pts, colours, _slowdown, _slowdown):
        ax.text(0.5, 0.5, f"no {NODE_NAMES[node]} slowdowns on both sides",
                transform=ax.transAxes, ha="center", va="center", color="0.5")
    if log:
        ax.set_xscale("log")
        ax.set_yscale("log")
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_major_formatter(FuncFormatter(lambda v, _: style.number(float(v))))
            axis.set_minor_formatter(FuncFormatter(lambda v, _: ""))
    ax.set_xlim(lim)
    ax.set_ylim(lim)
    ax.set_aspect("equal", adjustable="box")
    ax.grid(True, which="both" if log else "major", alpha=0.3)
    ax.set_xlabel(f"measured (hw) {style.SLOWDOWN_LABEL}" + (", log" if log else ""))
    ax.set_ylabel(f"simulated (sim) {style.SLOWDOWN_LABEL}" + (", log" if log else ""))
    ax.legend(loc="upper left", fontsize=7.5)
    _limits_note(ax, pts, lim)


def _excess(stat) -> tuple:
    return stat.mean - 1.0, stat.min - 1.0, stat.max - 1.0


def _excess_panel(ax, pairs, colours, excess_min) -> None:
    """Excess slowdown, log axes; only points whose measured excess is >= excess_min and
    whose simulated excess is positive (a log axis cannot show the others: counted below)."""
    shown = [p for p in pairs if p.hw.mean - 1.0 >= excess_min and p.sim.mean - 1.0 > 0]
    hidden = sum(1 for p in pairs if p.hw.mean - 1.0 >= excess_min) - len(shown)
    # Error bars end at a small positive value where a repetition's excess is <= 0.
    floor = excess_min / 10.0
    values = [v for p in shown if not disturbed(p)
              for v in (p.hw.mean - 1, p.sim.mean - 1) if _finite(v)]       # as above
    lo, hi = (min(values), max(values)) if values else (excess_min, 1.0)
    lim = (lo / 2.0, hi * 2.0)
    x = np.geomspace(lim[0], lim[1], 50)
    width, shade, label = EXCESS_BAND
    ax.fill_between(x, x * (1 - width), x * (1 + width), color=shade, linewidth=0,
                    label=f"{label} of measured", zorder=0)
    ax.plot(lim, lim, color="0.35", linestyle="--", linewidth=1.0, label="sim = hw", zorder=1)

    def clipped(stat):
        m, a, b = _excess(stat)
        return m, max(a, floor), max(b, floor)

    _errorbars(ax, shown, colours, clipped, clipped,
               lambda p: band_of(p, shift=1.0, floor=floor))
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(lim)
    ax.set_ylim(lim)
    ax.set_aspect("equal", adjustable="box")
    ax.grid(True, which="both", alpha=0.25)
    ax.set_xlabel("measured (hw) excess slowdown (slowdown − 1), log")
    ax.set_ylabel("simulated (sim) excess slowdown (slowdown − 1), log")
    ax.legend(loc="upper left", fontsize=7.5)
    if not shown or hidden:
        text = (f"{hidden} point(s) with measured excess ≥ {excess_min:g} not shown "
                "(simulated excess ≤ 0)" if hidden else
                f"no point with measured excess ≥ {excess_min:g}")
        ax.text(0.98, 0.02, text, transform=ax.transAxes, ha="right", va="bottom",
                fontsize=7.5, color="0.4")
    _limits_note(ax, shown, lim, shift=1.0, y=0.07)



def _per_k_panel(ax, rows, goals) -> None:
    """MAPE vs k: RT and nRT (every co-runner) per k, the per-node nRT MAPEs' min-max as a bar
    on the nRT marker, each goal as a horizontal line of its node's colour."""
    colour = {"rt": style.colour(0), "nrt": style.colour(1)}
    ks = [r["k"] for r in rows]
    for node in ("rt", "nrt"):
        ys = [r[node]["mape_pct"] for r in rows]
        shown = [(k, y) for k, y in zip(ks, ys) if _finite(y)]
        if shown:
            ax.plot(*zip(*shown), marker=NODE_MARKERS[node], color=colour[node],
                    markerfacecolor="none", label=f"{NODE_NAMES[node]} MAPE"
                    + (" (all co-runners)" if node == "nrt" else ""))
        if node in goals:
            ax.axhline(goals[node], color=colour[node], linestyle=":", linewidth=1.0,
                       label=f"{NODE_NAMES[node]} goal ≤ {goals[node]:g} %")
    for r in rows:
        nodes, y = r["nrt_nodes"], r["nrt"]["mape_pct"]
        if nodes["nodes"] > 1 and _finite(y):
            below, above = bar_lengths(y, nodes["min_mape_pct"], nodes["max_mape_pct"])
            ax.errorbar([r["k"]], [y], yerr=[[below], [above]], color=colour["nrt"],
                        capsize=3, linestyle="none", elinewidth=1.0)
    if not ks:
        ax.text(0.5, 0.5, "no scenario compared", transform=ax.transAxes, ha="center",
                va="center", color="0.5")
    else:
        ax.set_xticks(ks, [str(k) for k in ks])
        ax.set_xlim(min(ks) - 0.5 - 0.05 * max(ks), max(ks) + 0.5 + 0.05 * max(ks))
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    ax.set_xlabel("co-runners k (nRT nodes beside the RT node)")
    ax.set_ylabel("slowdown MAPE (%)")
    ax.set_title("MAPE per number of co-runners; bar: nRT MAPE per node, min–max", fontsize=9)
    ax.legend(loc="upper left", fontsize=7.5)

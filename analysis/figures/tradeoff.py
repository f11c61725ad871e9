"""RT vs nRT trade-off: which regulation setting protects the RT node at what price.

One panel per workload pair (per value of every configuration column that is not a
regulation setting) and nRT node (``analysis.nodes``: with several nRT nodes, a panel for each,
titled with its name); in it one marker per regulation setting (policy, sampling mode, sampling
and regulation periods, threshold or budget): x = the RT node's mean slowdown, y = the nRT
node's. x is the RT side because that is what a user bounds ("keep the RT node within 5 %"):
the target is a vertical line and every setting left of it meets the bound; lower is better on
both axes, so the best settings sit bottom left. The Pareto front (the settings no other
setting beats on both slowdowns) is drawn as a grey staircase through ringed markers, each
labelled with the setting words that are not the series' own.

Colours and markers are one per mechanism (policy and sampling mode). The unregulated co-run
(policy none) is a red star: what the RT node suffers and the nRT node gets without regulation.
Points whose policy is none are that star, not a setting.

With a tune.json (``rosguard tune``: {"rt_slowdown_max": X, "best": {...}, "runner_up": {...},
"unregulated": {...}}) the target is its rt_slowdown_max (``--rt-slowdown-max`` overrides it),
and its best and runner-up settings are marked with a gold and a silver star. A setting object
is matched against the points by, in this order: "point" (a point id); else its keys that are
configuration columns of the folder ("policy", "threshold_pct", ...; a "regulation.X" key means
the column X); else it is drawn where its "rt_slowdown" and "nrt_slowdown" say (only on a
figure with a single panel and a single nRT node: tune's nrt_slowdown is the mean over the nRT
nodes). "unregulated" with rt_slowdown / nrt_slowdown is drawn as the star
when the folder has no unregulated columns.

Applies when some workload pair has at least two regulation settings with both slowdowns.
"""

from __future__ import annotations

import math
from functools import partial

from analysis import style
from analysis.configs import (as_config, column_words, describe, finite, group_by, held_fixed,
                              key_of, keys_in_order, title, varying)
from analysis.figures import reference
from analysis.figures.base import FigurePlan
from analysis.nodes import cell_column, nodes_of

KIND = "RT vs nRT trade-off"
STEM = "tradeoff"
MECHANISM = ("policy", "sampling")
SETTING_COLUMNS = ("policy", "sampling", "sampling_period_us", "regulation_period_us",
                   "threshold_pct", "scope", "reference_mbps")
PANELS_PER_FILE = 12
PANEL_COLUMNS = 4
LEGEND_WIDTH_IN = 2.5
FRONT_STYLE = {"color": "0.3", "linewidth": 1.1, "drawstyle": "steps-post", "zorder": 2}
TUNE_MARKS = (("best", "best (tune)", "gold", 330),
              ("runner_up", "runner-up (tune)", "silver", 260))


def setting_columns(results) -> list:
    """The configuration columns that make a regulation setting in this folder: the
    regulation columns, and swept regulation paths or budgets of their own."""
    extra = [c for c in results.config_columns
             if c.startswith("param:regulation.") or "budget" in c]
    return [c for c in (*SETTING_COLUMNS, *extra) if c in results.config_columns]


def pareto_front(points, y: str = "nrt_slowdown") -> list:
    """The points no other point beats on both mean slowdowns (RT and the nRT node's column
    ``y``, lower is better), by ascending RT slowdown."""
    ordered = sorted(points, key=lambda p: (p.mean("rt_slowdown"), p.mean(y)))
    front, best_nrt = [], math.inf
    for p in ordered:
        if p.mean(y) < best_nrt:
            front.append(p)
            best_nrt = p.mean(y)
    return front


def plan(results):
    """FigurePlans (a panel per workload pair and nRT node, PANELS_PER_FILE per file), or a
    skip reason."""
    points = [p for p in results.points if p.has_rt and p.has_nrt and p.stat("rt_slowdown")]
    settings_cols = setting_columns(results)
    group_cols = varying(points, [c for c in results.config_columns if c not in settings_cols])
    nodes = nodes_of(results, "nrt")
    groups = [(key, node, measured) for key, pts in group_by(points, group_cols).items()
              for node in nodes
              for measured in [[p for p in pts if p.stat(node.metric)]]
              if len(_settings(measured)) >= 2]
    if not groups:
        return ("no workload pair has two regulation settings with RT and nRT slowdowns: "
                "no trade-off to draw")
    chunks = [groups[i:i + PANELS_PER_FILE] for i in range(0, len(groups), PANELS_PER_FILE)]
    mechanisms = keys_in_order([p for _, _, pts in groups for p in _settings(pts)], MECHANISM)
    plans = []
    for i, chunk in enumerate(chunks):
        stem = STEM if len(chunks) == 1 else f"{STEM}_{i + 1}"
        count = sum(len(_settings(pts)) for _, _, pts in chunk)
        summary = (f"RT vs nRT slowdown, one marker per regulation setting ({count} in "
                   f"{len(chunk)} panel(s)), the Pareto front marked")
        if group_cols:
            summary += "; a panel per " + ", ".join(column_words(c) for c in group_cols)
        if len(nodes) > 1:
            summary += "; a panel per nRT node (" + ", ".join(n.label for n in nodes) + ")"
        if results.rt_slowdown_max is not None:
            summary += f"; target RT slowdown ≤ {results.rt_slowdown_max:g}"
        if results.tune:
            summary += "; tune.json's best and runner-up marked"
        if len(chunks) > 1:
            summary += f" (part {i + 1} of {len(chunks)})"
        plans.append(FigurePlan(KIND, stem, summary,
                                partial(_draw, results, chunk, group_cols, settings_cols,
                                        mechanisms, len(groups) == 1 and len(nodes) == 1)))
    return plans


def _settings(points) -> list:
    """The points that are regulation settings (policy none is the unregulated co-run)."""
    return [p for p in points if p.config.get("policy") != "none"]


def _draw(results, chunk, group_cols, settings_cols, mechanisms, single):
    ncols = min(PANEL_COLUMNS, len(chunk))
    nrows = math.ceil(len(chunk) / ncols)
    width = 4.2 * ncols + LEGEND_WIDTH_IN
    fig, axes = style.new_figure(nrows, ncols, width=width, row_height=3.6)
    handles: dict = {}
    all_points = [p for _, _, pts in chunk for p in pts]
    label_cols = varying(_settings(all_points),
                         [c for c in settings_cols if c not in MECHANISM])
    several = any(node.several for _, node, _ in chunk)
    for i, (key, node, points) in enumerate(chunk):
        ax = axes[i // ncols][i % ncols]
        _draw_panel(ax, results, points, mechanisms, label_cols, single, node)
        words = describe(as_config(group_cols, key))
        if several:
            words = f"{node.label}" + (f"\n{words}" if words else "")
        if words:
            ax.set_title(words, fontsize=9)
        for h, label in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(label, h)
    for j in range(len(chunk), nrows * ncols):
        axes[j // ncols][j % ncols].set_visible(False)
    right = 1.0 - LEGEND_WIDTH_IN / width
    fig.legend(list(handles.values()), list(handles.keys()), loc="center left",
               bbox_to_anchor=(right, 0.5), fontsize=8, frameon=False)
    fixed = held_fixed(all_points, [c for c in results.config_columns
                                    if c not in group_cols and c not in settings_cols])
    style.finish(fig, title("RT vs nRT slowdown trade-off per regulation setting", fixed,
                            results), _note(results, all_points, label_cols), right=right)
    return fig


def _draw_panel(ax, results, points, mechanisms, label_cols, single, node) -> None:
    settings = _settings(points)
    y = node.metric
    for key, pts in group_by(settings, list(MECHANISM)).items():
        index = mechanisms.index(key)
        ax.scatter([p.mean("rt_slowdown") for p in pts], [p.mean(y) for p in pts],
                   color=style.colour(index), marker=style.marker(index), s=36, zorder=3,
                   label=describe(as_config(MECHANISM, key), short=True))
    front = pareto_front(settings, y)
    ax.plot([p.mean("rt_slowdown") for p in front], [p.mean(y) for p in front],
            label="Pareto front", **FRONT_STYLE)
    ax.scatter([p.mean("rt_slowdown") for p in front], [p.mean(y) for p in front],
               s=110, facecolors="none", edgecolors="0.2", linewidths=1.0, zorder=2.5)
    _draw_unregulated(ax, results, points, single, node)
    _draw_tune(ax, results, points, single, y)
    _label_front(ax, front, label_cols, y)
    reference.draw_target(ax, results.rt_slowdown_max, vertical=True)
    if results.rt_slowdown_max is not None:
        lo, hi = ax.get_xlim()
        if hi > results.rt_slowdown_max:
            ax.axvspan(results.rt_slowdown_max, hi, color="0.5", alpha=0.08, zorder=0)
        ax.set_xlim(lo, hi)
    ax.set_xlabel(f"RT {style.SLOWDOWN_LABEL}")
    ax.set_ylabel(f"{node.label if node.several else 'nRT'} {style.SLOWDOWN_LABEL}")
    ax.grid(True, alpha=0.3)


def _label_front(ax, front, label_cols, y, min_dx=60, min_dy=11) -> None:
    """Labels the front's settings with their words where a label fits: settings at (nearly)
    the same place share one; a label closer than min_dx x min_dy pixels to one already
    written is left out."""
    ax.get_xlim(), ax.get_ylim()   # settle the autoscaled limits before using transData
    placed: list = []
    # Where the front mixes mechanisms, each label names its own (25 % of interval and 25 % of
    # monolithic are two settings).
    mixed = len({key_of(p, list(MECHANISM)) for p in front}) > 1

    def words_of(p) -> str:
        w = _setting_words(p, label_cols)
        if not mixed:
            return w
        return ": ".join(x for x in (describe(as_config(MECHANISM, key_of(p, list(MECHANISM))),
                                              short=True), w) if x)

    for cluster in _clusters(front, y):
        words = " / ".join(dict.fromkeys(w for w in (words_of(p) for p in cluster) if w))
        xy = (cluster[0].mean("rt_slowdown"), cluster[0].mean(y))
        px, py = ax.transData.transform(xy)
        if not words or any(abs(px - qx) < min_dx and abs(py - qy) < min_dy
                            for qx, qy in placed):
            continue
        placed.append((px, py))
        ax.annotate(words, xy, xytext=(5, 4), textcoords="offset points", fontsize=6.5,
                    color="0.25")


def _clusters(front, y, rel=2e-3) -> list:
    """Consecutive front points within ``rel`` of each other on both axes, grouped."""
    clusters: list = []
    for p in front:
        last = clusters[-1][0] if clusters else None
        if last is not None and all(math.isclose(p.mean(m), last.mean(m), rel_tol=rel)
                                    for m in ("rt_slowdown", y)):
            clusters[-1].append(p)
        else:
            clusters.append([p])
    return clusters


def _setting_words(point, columns) -> str:
    words = []
    for c in columns:
        v = point.config.get(c)
        if c == "threshold_pct":
            words.append(f"{style.number(v)} %")
        elif c.endswith("_period_us"):
            words.append(("reg. " if c.startswith("regulation") else "") + style.period(v))
        else:
            words.append(f"{column_words(c)} {style.number(v)}")
    return ", ".join(words)


def _draw_unregulated(ax, results, points, single, node) -> None:
    """The unregulated co-run of the panel's nRT node (older folders have it for the first nRT
    node only: the other panels then have none)."""
    column = cell_column(results, node, "unregulated_slowdown")
    pairs = []
    for p in points:
        rt = p.stat("rt_unregulated_slowdown")
        nrt = p.stat(column) if column else None
        if rt and nrt and not any(math.isclose(rt.mean, a) and math.isclose(nrt.mean, b)
                                  for a, b in pairs):
            pairs.append((rt.mean, nrt.mean))
    given = results.tune.get("unregulated") or {}
    if not pairs and single and node.index == 0 and all(finite(given.get(k)) for k in ("rt_slowdown",
                                                                     "nrt_slowdown")):
        pairs.append((float(given["rt_slowdown"]), float(given["nrt_slowdown"])))
    for rt, nrt in pairs:
        ax.scatter([rt], [nrt], marker="*", s=170, color=style.UNREGULATED_STYLE["color"],
                   edgecolors="black", linewidths=0.5, zorder=4, label=style.UNREGULATED_LABEL)


def matches(entry: dict, point, config_columns) -> bool:
    """True when a tune.json setting object names this point (see the module doc)."""
    if entry.get("point") is not None:
        return entry["point"] == point.id
    matched = False
    for key, value in entry.items():
        column = key[len("regulation."):] if key.startswith("regulation.") else key
        if column not in config_columns:
            continue
        have = point.config.get(column)
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            if not (finite(have) and math.isclose(float(have), float(value))):
                return False
        elif have != value:
            return False
        matched = True
    return matched


def _draw_tune(ax, results, points, single, y) -> None:
    for key, label, colour, size in TUNE_MARKS:
        entry = results.tune.get(key)
        if not entry:
            continue
        chosen = [p for p in points if matches(entry, p, results.config_columns)]
        xy = [(p.mean("rt_slowdown"), p.mean(y)) for p in chosen]
        if not xy and single and all(finite(entry.get(k)) for k in ("rt_slowdown",
                                                                     "nrt_slowdown")):
            xy = [(float(entry["rt_slowdown"]), float(entry["nrt_slowdown"]))]
        for mark_x, mark_y in xy:
            ax.scatter([mark_x], [mark_y], marker="*", s=size, color=colour, edgecolors="black",
                       linewidths=0.7, zorder=5, label=label)


def _note(results, points, label_cols) -> str:
    note = (f"markers: mean over {results.repetitions} repetitions, one per regulation "
            "setting; lower left is better (x: the RT node's slowdown, which a target bounds; "
            "y: what the nRT node pays); staircase through ringed markers: the Pareto front "
            "(no other setting is better on both)")
    if label_cols:
        note += ("; front labels (where they fit): "
                 + ", ".join(column_words(c) for c in label_cols)
                 + ", after the mechanism where the front has several")
    if any(p.stat("rt_unregulated_slowdown") for p in points):
        note += "; red star: the unregulated co-run (policy none)"
    if results.rt_slowdown_max is not None:
        note += (f"; dotted: the target RT slowdown ≤ {results.rt_slowdown_max:g} "
                 "(shaded: over it)")
    if results.tune:
        note += "; stars: the best and runner-up setting rosguard tune chose (tune.json)"
    return note

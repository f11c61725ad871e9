"""``compare A B [--out DIR]``: two results folders point by point (e.g. hw vs sim).

Points are matched by their stable id (it depends only on the sweep parameters, so a sim
run and a hw run of the same scenario share ids). Each point's slowdown of every RT and nRT
node is averaged over its repetitions first. A is the reference (e.g. measured), B the folder
compared with it (e.g. simulated); errors are B - A.

Nodes are named by their points.csv prefix without the underscore (``rt``, ``nrt`` the first
nRT node, ``nrt1`` the second, ...; ``analysis.nodes``) and their scenario name.

Writes into the output folder (default ``B/compare``):

* ``compare.csv``: one row per point (common, only in A, only in B) with the settings, the
  repetitions on each side, and per node its name, slowdown in A and B, difference (B - A)
  and error in % of A (``nrt1_name``, ``nrt1_slowdown_a``, ...);
* ``summary.json``: per node (``"rt"``, ``"nrt"``, ``"nrt1"``, ...: its role, index and name)
  the number of pairs, mean absolute percentage error, max absolute error (and where), mean
  error (bias), Spearman rank correlation of the configurations' slowdowns; the same over all
  nodes of a role (``"overall": {"rt": ..., "nrt": ...}``: every node's pairs together); the
  points only in A / only in B; settings that differ between matched points;
* ``compare_scatter.png`` / ``.pdf``: B vs A slowdown per point, a panel per node (titled with
  its name and errors), with the identity line.

With ``--band DIR`` (repeatable): DIR holds a run of B's scenario on one of the uncertainty-band
platforms of B's model (``rosguard calibrate`` writes them: one prior-dominated parameter one
posterior standard error down or up, the rest as fitted). Per point and node, B's **prediction
band** is min..max of the mean slowdown over B and every band folder that has the point (the
envelope of one-at-a-time variations, not a joint interval). compare.csv then has
``<node>_band_low_b`` / ``<node>_band_high_b``, summary.json a ``band`` object (per node: the
points with a band, how many of them have A's mean inside it, the coverage in % and the median
width), the printed summary one line per node, and the scatter draws the band as a vertical bar
on each of B's points. A band folder that lacks some of B's points gives a warning; those points'
band is made from the folders that have them (none: no band).
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import scipy.stats

from analysis import style
from analysis.figures.validation import bar_lengths
from analysis.nodes import ROLES, nodes_of
from analysis.results import InvalidInput, load_results
from analysis.tables import write_csv

SETTINGS = ("rt_workload", "nrt_workload", "policy", "sampling", "scope", "threshold_pct",
            "sampling_period_us", "regulation_period_us")
NODE_STYLE = {"rt": {"marker": "o", "color": "tab:blue"},
              "nrt": {"marker": "^", "color": "tab:orange"}}   # per role
LISTED_IDS = 8   # ids printed per "only in" list; summary.json has them all
BAND_DEFINITION = (
    "per point and node, min..max of the mean slowdown over the nominal run and every band run "
    "that has the point (each band run: one prior-dominated parameter of the model one "
    "posterior standard error down or up, the others as fitted): the envelope of "
    "one-at-a-time variations, not a joint confidence interval")
BAND_STYLE = {"linewidth": 5.0, "alpha": 0.3}


@dataclass
class ErrorSummary:
    """Agreement of one node's mean slowdowns over the common points."""

    pairs: int
    mape_pct: float
    max_abs_error: float
    max_abs_error_point: str | None
    mean_error: float
    spearman: float


@dataclass
class Comparison:
    """Two folders matched point by point."""

    a: object
    b: object
    common: list          # [(Point in A, Point in B)]
    only_a: list          # [Point]
    only_b: list          # [Point]
    mismatches: list      # [(point id, {column: (value in A, value in B)})]
    nodes: list           # [analysis.nodes.Node] of A and B (B's where both have it)
    errors: dict          # {node key ("rt", "nrt", "nrt1", ...): ErrorSummary}
    overall: dict         # {"rt" | "nrt": ErrorSummary over every node of the role}


@dataclass
class Band:
    """The prediction band of one results folder (the nominal run) from runs of the same
    scenario on the band platforms of its model."""

    folders: list         # [Path] the band runs, in the order given
    bounds: dict          # point id of the nominal run -> {node key: (low, high)}
    missing: dict         # str(folder) -> [ids of the nominal run's points not in it]
    mismatches: dict      # str(folder) -> number of matched points with other settings

    def of(self, pid: str, node: str) -> tuple:
        """(low, high) of a point's node; (NaN, NaN) where it has none."""
        return self.bounds.get(pid, {}).get(node, (math.nan, math.nan))


def prediction_band(nominal, runs) -> Band:
    """The band of ``nominal`` (loaded results) from ``runs`` (loaded results of the same
    scenario on band platforms): per point and node, min..max of the finite mean slowdowns of
    the nominal run and of every run that has the point. A point no run has gets no band
    (NaN, NaN): the nominal value alone is no envelope. InvalidInput when a run shares no point
    with the nominal one (another scenario)."""
    nodes = nodes_of(nominal)
    values = {p.id: {n.key: [p.mean(n.metric)] for n in nodes} for p in nominal.points}
    seen = {p.id: 0 for p in nominal.points}
    missing, mismatches = {}, {}
    for run in runs:
        comp = compare_results(nominal, run)         # InvalidInput: no common point
        for pn, pr in comp.common:
            seen[pn.id] += 1
            for n in nodes:
                values[pn.id][n.key].append(pr.mean(n.metric))
        if comp.only_a:
            missing[str(run.folder)] = [p.id for p in comp.only_a]
        if comp.mismatches:
            mismatches[str(run.folder)] = len(comp.mismatches)
    bounds = {}
    for pid, nodes in values.items():
        if not seen[pid]:
            continue
        bounds[pid] = {}
        for node, vs in nodes.items():
            finite = [v for v in vs if math.isfinite(v)]
            bounds[pid][node] = (min(finite), max(finite)) if finite else (math.nan, math.nan)
    return Band([r.folder for r in runs], bounds, missing, mismatches)


def band_coverage(triples) -> dict:
    """Over [(reference value, band low, band high)]: 'points' (those with a finite value and
    band), 'covered' (low <= value <= high), 'coverage_pct' and 'median_width' (high - low, in
    slowdown units); NaN where there is no such point."""
    usable = [(v, lo, hi) for v, lo, hi in triples
              if math.isfinite(v) and math.isfinite(lo) and math.isfinite(hi)]
    covered = sum(1 for v, lo, hi in usable if lo <= v <= hi)
    return {"points": len(usable), "covered": covered,
            "coverage_pct": 100.0 * covered / len(usable) if usable else math.nan,
            "median_width": float(np.median([hi - lo for _, lo, hi in usable]))
            if usable else math.nan}


def band_warnings(band: Band, points: int) -> list:
    """One line per band folder that lacks points of the nominal run or whose matched points
    have other settings, and one for the points no band folder has (they get no band)."""
    lines = []
    for folder, ids in band.missing.items():
        shown = ", ".join(ids[:LISTED_IDS]) + (", ..." if len(ids) > LISTED_IDS else "")
        lines.append(f"band folder {folder} lacks {len(ids)} of {points} point(s) ({shown}); "
                     "their band is made from the folders that have them")
    for folder, count in band.mismatches.items():
        lines.append(f"band folder {folder}: {count} matched point(s) differ in their settings; "
                     "is it a run of the same scenario?")
    none = points - len(band.bounds)
    if none and band.folders:
        lines.append(f"{none} point(s) are in no band folder: no band for them")
    return lines


def spearman(x, y) -> float:
    """Spearman rank correlation (scipy); NaN for fewer than 2 pairs or a constant side."""
    if len(x) < 2:
        return math.nan
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if np.all(x == x[0]) or np.all(y == y[0]):
        return math.nan
    return float(scipy.stats.spearmanr(x, y).correlation)


def error_summary(pairs) -> ErrorSummary:
    """Errors of B against A over [(point id, a, b)] with finite a and b."""
    if not pairs:
        return ErrorSummary(0, math.nan, math.nan, None, math.nan, math.nan)
    ids = [p for p, _, _ in pairs]
    a = np.array([x for _, x, _ in pairs])
    b = np.array([y for _, _, y in pairs])
    diff = b - a
    nonzero = a != 0
    mape = float(np.mean(np.abs(diff[nonzero]) / np.abs(a[nonzero])) * 100) \
        if nonzero.any() else math.nan
    worst = int(np.argmax(np.abs(diff)))
    return ErrorSummary(len(pairs), mape, float(abs(diff[worst])), ids[worst],
                        float(diff.mean()), spearman(a, b))


def compare_results(a, b) -> Comparison:
    """Matches two loaded folders by point id and computes the error summaries."""
    in_b = {p.id: p for p in b.points}
    in_a = {p.id for p in a.points}
    common = [(p, in_b[p.id]) for p in a.points if p.id in in_b]
    if not common:
        raise InvalidInput(f"{a.folder} and {b.folder} share no point: their sweep parameters "
                           "differ (compare runs of the same scenario)")
    only_a = [p for p in a.points if p.id not in in_b]
    only_b = [p for p in b.points if p.id not in in_a]
    mismatches = []
    for pa, pb in common:
        diff = {c: (pa.config.get(c), pb.config.get(c)) for c in SETTINGS
                if pa.config.get(c) != pb.config.get(c)}
        if diff:
            mismatches.append((pa.id, diff))
    nodes = {n.key: n for n in nodes_of(a)}
    nodes.update({n.key: n for n in nodes_of(b)})
    nodes = sorted(nodes.values(), key=lambda n: (n.role != "rt", n.index))
    errors, by_role = {}, {}
    for n in nodes:
        pairs = [(pa.id, pa.mean(n.metric), pb.mean(n.metric)) for pa, pb in common]
        pairs = [t for t in pairs if math.isfinite(t[1]) and math.isfinite(t[2])]
        errors[n.key] = error_summary(pairs)
        by_role.setdefault(n.role, []).extend((f"{pid} {n.key}", va, vb) for pid, va, vb in pairs)
    overall = {role: error_summary(by_role.get(role, [])) for role, _ in ROLES}
    return Comparison(a, b, common, only_a, only_b, mismatches, nodes, errors, overall)


def run(folder_a, folder_b, out=None, stream=sys.stdout, err=sys.stderr, bands=()) -> int:
    """Compares two results folders and writes the outputs; returns the exit code (0).
    ``bands``: results folders of B's scenario on B's model's band platforms (see the module
    docstring); none: the outputs carry no band."""
    a, b = load_results(folder_a), load_results(folder_b)
    comp = compare_results(a, b)
    band = prediction_band(b, [load_results(f) for f in bands]) if bands else None
    out = Path(out) if out else b.folder / "compare"
    out.mkdir(parents=True, exist_ok=True)
    written = [write_table(comp, out / "compare.csv", band),
               write_summary(comp, out / "summary.json", band)]
    written += style.save(scatter(comp, band), out, "compare_scatter")
    print_summary(comp, stream, band)
    if comp.mismatches:
        pid, diff = comp.mismatches[0]
        example = "; ".join(f"{c} {va} vs {vb}" for c, (va, vb) in diff.items())
        print(f"warning: {len(comp.mismatches)} matched point(s) differ in their settings "
              f"(e.g. {pid}: {example}); did A and B run the same scenario?", file=err)
    if band is not None:
        for line in band_warnings(band, len(b.points)):
            print(f"warning: {line}", file=err)
    print("written: " + ", ".join(str(p) for p in written), file=stream)
    return 0


def write_table(comp: Comparison, path: Path, band: Band | None = None) -> Path:
    """compare.csv: one row per point, common ones first (in A's order); per node its name
    and slowdowns; with a band, each node's band of B after its columns."""
    header = ["point", "status", *SETTINGS, "reps_a", "reps_b"]
    for n in comp.nodes:
        header += [f"{n.key}_name", f"{n.key}_slowdown_a", f"{n.key}_slowdown_b",
                   f"{n.key}_diff", f"{n.key}_error_pct"]
        if band is not None:
            header += [f"{n.key}_band_low_b", f"{n.key}_band_high_b"]
    rows = [_row(comp.nodes, pa.id, "both", pa, pb, band) for pa, pb in comp.common]
    rows += [_row(comp.nodes, p.id, "only_a", p, None, band) for p in comp.only_a]
    rows += [_row(comp.nodes, p.id, "only_b", None, p, band) for p in comp.only_b]
    return write_csv(path, header, rows)


def _row(nodes, pid, status, pa, pb, band=None) -> list:
    ref = pa or pb
    row = [pid, status, *(ref.config.get(c) for c in SETTINGS),
           pa.reps if pa else None, pb.reps if pb else None]
    for n in nodes:
        va = pa.mean(n.metric) if pa else math.nan
        vb = pb.mean(n.metric) if pb else math.nan
        diff = vb - va
        pct = 100.0 * diff / va if va else math.nan
        row += [n.name, va, vb, diff, pct]
        if band is not None:
            row += list(band.of(pid, n.key) if pb else (math.nan, math.nan))
    return row


def _json_number(value):
    return value if not (isinstance(value, float) and not math.isfinite(value)) else None


def _side(results) -> dict:
    return {"folder": str(results.folder), "backend": results.backend,
            "platform": results.platform, "status": results.status,
            "points": len(results.points), "prior_dominated": _prior_dominated(results)}


def _prior_dominated(results) -> list:
    """The fitted model's parameters that rest mostly on their priors (a sim run's manifest)."""
    return list(results.manifest.get("prior_dominated") or [])


def _band(q: dict) -> str:
    """'dram.bandwidth_mbps 5.1e+04 (1.9e+04..1.4e+05)': the value and its one-standard-error
    band (a factor exp(log_std_error) either way)."""
    f = math.exp(q["log_std_error"])
    v = q["value"]
    return f"{q['parameter']} {v:.3g} ({v / f:.3g}..{v * f:.3g})"


def band_summary(comp: Comparison, band: Band) -> dict:
    """summary.json's "band": the folders, the definition, and per node (key) A's coverage by
    B's band over the common points (band_coverage)."""
    doc = {"folders": [str(f) for f in band.folders], "definition": BAND_DEFINITION,
           "missing": band.missing, "settings_mismatch": band.mismatches}
    for n in comp.nodes:
        doc[n.key] = band_coverage([(pa.mean(n.metric), *band.of(pb.id, n.key))
                                    for pa, pb in comp.common])
    return doc


def write_summary(comp: Comparison, path: Path, band: Band | None = None) -> Path:
    """summary.json: the error summaries, unmatched points and settings mismatches (and, with
    a band, its coverage: band_summary)."""
    doc = {
        "a": _side(comp.a),
        "b": _side(comp.b),
        "common_points": len(comp.common),
        "only_in_a": [p.id for p in comp.only_a],
        "only_in_b": [p.id for p in comp.only_b],
        "settings_mismatch": [{"point": pid, "columns": {c: list(v) for c, v in d.items()}}
                              for pid, d in comp.mismatches],
        "definitions": {
            "error": "B - A, in slowdown units (x isolation), on means over repetitions",
            "mape_pct": "mean over points of |B - A| / |A| x 100",
            "max_abs_error": "largest |B - A| (max_abs_error_point says where)",
            "mean_error": "mean of B - A (positive: B predicts more slowdown)",
            "spearman": "Spearman rank correlation of the points' slowdowns in A and B",
            "nodes": "rt, nrt: the first RT / nRT node; rt1, nrt1, ...: the second, ... (their "
                     "points.csv prefixes); name: the node's name in the scenario",
            "overall": "per role, the same figures over the pairs of every node of that role "
                       "(max_abs_error_point: '<point> <node>')",
        },
    }
    for n in comp.nodes:
        doc[n.key] = {"role": n.role, "index": n.index, "name": n.name,
                      **{k: _json_number(v) for k, v in asdict(comp.errors[n.key]).items()}}
    doc["overall"] = {role: {k: _json_number(v) for k, v in asdict(e).items()}
                      for role, e in comp.overall.items()}
    if band is not None:
        summary = band_summary(comp, band)
        for n in comp.nodes:
            summary[n.key] = {k: _json_number(v) for k, v in summary[n.key].items()}
        doc["band"] = summary
    path.write_text(json.dumps(doc, indent=2, default=str) + "\n", encoding="utf-8")
    return path


def print_summary(comp: Comparison, stream, band: Band | None = None) -> None:
    """The human-readable summary on stdout."""
    for tag, r in (("A", comp.a), ("B", comp.b)):
        print(f"{tag}: {r.folder} ({r.backend}, {r.platform}, {len(r.points)} points, "
              f"status {r.status})", file=stream)
        dominated = _prior_dominated(r)
        if dominated:
            print(f"   {tag}'s model rests on priors for {len(dominated)} parameter(s), with "
                  "one-standard-error bands: " + "; ".join(_band(q) for q in dominated),
                  file=stream)
    print(f"common points: {len(comp.common)}; only in A: {_ids(comp.only_a)}; "
          f"only in B: {_ids(comp.only_b)}", file=stream)
    # A row per node ("nRT1", its name last), then with several nodes of a role one over all
    # of them under the role's name ("nRT"); tools/validate.sh reads the "RT" / "nRT" rows.
    rows = [(n.tag, n.name, comp.errors[n.key]) for n in comp.nodes]
    for role, name in ROLES:
        several = sum(1 for n in comp.nodes if n.role == role)
        if several > 1:
            rows.append((name, f"overall: all {several} {name} nodes", comp.overall[role]))
    width = max([5, *(len(tag) + 1 for tag, _, _ in rows)])
    print(f"{'':{width}}{'pairs':>6}{'MAPE':>10}{'max |B-A|':>11}  {'at point':<13}"
          f"{'bias B-A':>9}{'Spearman':>10}  node", file=stream)
    for tag, name, e in rows:
        if not e.pairs:
            print(f"{tag:<{width}}{0:>6}  (no slowdowns on both sides)  {name}".rstrip(),
                  file=stream)
            continue
        print(f"{tag:<{width}}{e.pairs:>6}{_fmt(e.mape_pct, ' %'):>10}"
              f"{_fmt(e.max_abs_error):>11}  {e.max_abs_error_point:<13}"
              f"{_fmt(e.mean_error, signed=True):>9}{_fmt(e.spearman):>10}  {name}".rstrip(),
              file=stream)
    if band is not None:
        print(f"prediction band of B from {len(band.folders)} band run(s) (min..max over B and "
              "them, one prior-dominated parameter at a time):", file=stream)
        summary = band_summary(comp, band)
        for n in comp.nodes:
            c = summary[n.key]
            print(f"{n.tag:<{width}}B's band covers A at {c['covered']} of {c['points']} "
                  f"points, median width {_fmt(c['median_width'])}  {n.name}".rstrip(),
                  file=stream)


def _ids(points) -> str:
    if not points:
        return "0"
    shown = ", ".join(p.id for p in points[:LISTED_IDS])
    more = f", ... ({len(points) - LISTED_IDS} more in summary.json)" \
        if len(points) > LISTED_IDS else ""
    return f"{len(points)} ({shown}{more})"


def _fmt(value, unit: str = "", signed: bool = False) -> str:
    if value is None or not math.isfinite(value):
        return "n/a"
    return f"{value:+.3f}{unit}" if signed else f"{value:.3f}{unit}"


def scatter(comp: Comparison, band: Band | None = None):
    """B vs A mean slowdown per common point: one panel per node (RT, nRT, every further
    node, each titled with its name), each with its own limits (RT slowdowns sit near 1.0, nRT
    ones spread far wider) and the identity line; with a band, B's band as a vertical bar on
    each of B's points."""
    nodes = [(n, _pairs(comp, n.metric)) for n in comp.nodes]
    nodes = [t for t in nodes if t[1]] or [(None, [])]
    fig, axes = style.new_figure(1, len(nodes), width=5.0 * len(nodes), row_height=4.8)
    for ax, (n, pairs) in zip(axes[0], nodes):
        bands = None
        if band is not None and n is not None:
            bands = [band.of(pb.id, n.key) for pa, pb in comp.common
                     if pa.stat(n.metric) and pb.stat(n.metric)]
        errors = comp.errors[n.key] if n else error_summary([])
        _scatter_panel(ax, n.role if n else "rt", n.label if n else "RT", pairs, errors, bands)
        ax.set_xlabel(f"A: {_name(comp.a)}\n{style.SLOWDOWN_LABEL}")
        ax.set_ylabel(f"B: {_name(comp.b)}\n{style.SLOWDOWN_LABEL}")
    head = (f"Slowdown per point, B vs A ({len(comp.common)} common points, "
            f"{len(comp.only_a)} only in A, {len(comp.only_b)} only in B)")
    note = ("markers: mean over repetitions; error bars: min–max over repetitions on each "
            "side; dashed: identity (B = A)")
    if band is not None:
        note += (f"; wide pale bars: B's prediction band (min..max over B and "
                 f"{len(band.folders)} band run(s), one prior-dominated parameter ±1 standard "
                 "error at a time)")
    style.finish(fig, head, note)
    return fig


def _pairs(comp: Comparison, metric: str) -> list:
    return [(pa.stat(metric), pb.stat(metric)) for pa, pb in comp.common
            if pa.stat(metric) and pb.stat(metric)]


def _draw_band(ax, x, centre, bands, **style_kw) -> int:
    """Vertical band bars at x from (low, high) around centre: non-negative lengths (a bound on
    the wrong side of the centre, or NaN, draws nothing on that side); points with a
    non-finite x or centre are left out. Returns how many bars were drawn."""
    xs, ys, below, above = [], [], [], []
    for xi, yi, (lo, hi) in zip(x, centre, bands):
        if not (math.isfinite(xi) and math.isfinite(yi)) or not (
                math.isfinite(lo) or math.isfinite(hi)):
            continue
        b, a = bar_lengths(yi, lo, hi)
        xs.append(xi)
        ys.append(yi)
        below.append(b)
        above.append(a)
    if xs:
        ax.errorbar(xs, ys, yerr=[below, above], linestyle="none", marker="none", capsize=0,
                    elinewidth=BAND_STYLE["linewidth"], alpha=BAND_STYLE["alpha"], zorder=1.5,
                    **style_kw)
    return len(xs)


def _scatter_panel(ax, role: str, name: str, pairs, errors: ErrorSummary,
                   bands=None) -> None:
    """One node's points (``role`` picks the style, ``name`` is its label) with min-max error
    bars, identity line and square limits; ``bands`` ([(low, high)] per pair, or None): B's
    prediction band as a wide pale bar on each point."""
    lo, hi = 1.0, 1.0
    if pairs:
        sa = [p for p, _ in pairs]
        sb = [q for _, q in pairs]
        xa = np.array([s.mean for s in sa])
        yb = np.array([s.mean for s in sb])
        # Distances, never negative: the mean of equal repetitions can round past their max.
        xerr = np.array([bar_lengths(s.mean, s.min, s.max) for s in sa]).T
        yerr = np.array([bar_lengths(s.mean, s.min, s.max) for s in sb]).T
        ax.errorbar(xa, yb, xerr=xerr, yerr=yerr,
                    linestyle="none", markersize=6, markerfacecolor="none", elinewidth=0.7,
                    capsize=2, label=f"{name} ({len(pairs)} points)", **NODE_STYLE[role])
        lo = min(min(s.min for s in sa), min(s.min for s in sb))
        hi = max(max(s.max for s in sa), max(s.max for s in sb))
        if bands is not None:
            drawn = _draw_band(ax, xa, yb, bands, color=NODE_STYLE[role]["color"],
                               label=f"B's prediction band ({name})")
            ends = [v for lo_hi in bands for v in lo_hi if math.isfinite(v)]
            if drawn and ends:
                lo, hi = min(lo, min(ends)), max(hi, max(ends))
    else:
        ax.text(0.5, 0.5, "no slowdowns on both sides", transform=ax.transAxes,
                ha="center", va="center", color="0.5")
    pad = 0.06 * ((hi - lo) or 0.1)
    lim = (lo - pad, hi + pad)
    ax.plot(lim, lim, color="0.35", linestyle="--", linewidth=1.0, label="identity (B = A)")
    ax.set_xlim(lim)
    ax.set_ylim(lim)
    ax.set_aspect("equal", adjustable="box")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper left", fontsize=8)
    ax.set_title(f"{name}: MAPE {_fmt(errors.mape_pct, ' %')}, "
                 f"Spearman {_fmt(errors.spearman)}", fontsize=9)


def _name(results) -> str:
    role = {"hw": ", measured", "sim": ", simulated"}.get(results.backend, "")
    return f"{results.folder.name} [{results.backend}{role}]"

"""``plot DIR [--out DIR]``: every figure a results folder supports, and the numbers behind.

Writes into the output folder (default ``DIR/figures``):

* one PNG (150 dpi) and one PDF per figure the registry plans (``analysis.figures``);
* ``summary.csv``: per point, its configuration, each node's name (``rt_name``, ``nrt_name``,
  ``nrt1_name``, ...) and the mean / min / max / std over repetitions of every node's slowdown,
  time, bandwidth and throttling (nRT) or response times (RT: p99, max, deadline misses), the
  per-point delay columns and the isolation baselines' spread; a node's columns carry its
  points.csv prefix (``nrt_`` the first nRT node, ``nrt1_`` the second, ...);
* ``nodes.csv``: the tidy per-node table (``analysis.nodes``): one row per point, repetition
  and node with its role, index, name, core, workload, the regulation settings, and its time,
  isolation time, slowdown, bandwidth and throttling;
* ``distributions.csv``: per sample kind, sampling mode and sampling period, the count,
  min / median / max / mean of the samples (what the ▽ × △ figures show; ``rt_job``: each
  RT job's response time).

Prints the files written with a one-line summary each, and a one-line reason per figure
kind the data do not support.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from analysis import style
from analysis.configs import column_words, describe, group_by, varying
from analysis.figures import plan_figures
from analysis.nodes import cell_column, nodes_of, write_nodes
from analysis.results import InvalidInput, load_results
from analysis.tables import write_csv

# Per node (its points.csv prefix + these), then per point.
NODE_METRICS = {
    "rt": ("slowdown", "time_us", "response_p99_us", "response_max_us", "deadline_misses",
           "isolation_cv", "unregulated_slowdown"),
    "nrt": ("slowdown", "time_us", "bandwidth_mbps", "throttle_count", "throttled_us",
            "isolation_cv", "unregulated_slowdown"),
}
POINT_METRICS = (
    "activation_delay_p50_us", "activation_delay_max_us", "pmc_callback_p50_us",
    "pmc_callback_max_us", "sampling_overhead_p50_us",
)
SAMPLE_KINDS = ("activation_delay", "pmc_callback", "sampling_overhead", "rt_job")
STATS = ("mean", "min", "max", "std")


def run(folder, out=None, stream=sys.stdout, rt_slowdown_max=None) -> int:
    """Draws every supported figure of a results folder; returns the exit code (0).
    ``rt_slowdown_max``: the RT slowdown target to draw (overrides tune.json's)."""
    results = load_results(folder)
    if rt_slowdown_max is not None:
        if results.tune.get("rt_slowdown_max") not in (None, rt_slowdown_max):
            print(f"note: drawing the target {rt_slowdown_max:g} given on the command line, "
                  f"not tune.json's {results.tune['rt_slowdown_max']:g}", file=stream)
        results.rt_slowdown_max = rt_slowdown_max
    if not results.rows:
        raise InvalidInput(f"{results.folder / 'points.csv'} holds no rows yet "
                           f"(run status: {results.status}): nothing to plot")
    out = Path(out) if out else results.folder / "figures"
    out.mkdir(parents=True, exist_ok=True)
    print(f"{results.folder}: {results.backend} backend, {results.platform}, "
          f"{len(results.points)} point(s) x up to {results.repetitions} repetition(s) "
          f"(status {results.status})", file=stream)
    if results.status != "complete":
        print("note: the run is not complete; figures show the rows written so far",
              file=stream)

    plans, skipped = plan_figures(results)
    print(f"figures in {out}:" if plans else "no figure applies to these results", file=stream)
    for plan in plans:
        png, pdf = style.save(plan.draw(), out, plan.stem)
        print(f"  {png.name}, {pdf.name}: {plan.summary}", file=stream)
    for s in skipped:
        print(f"  skipped {s.kind}: {s.reason}", file=stream)

    tables = [write_summary(results, out / "summary.csv"),
              write_nodes(results, out / "nodes.csv")]
    if any(kind in results.sample_kinds() for kind in SAMPLE_KINDS):
        tables.append(write_distributions(results, out / "distributions.csv"))
    print("tables: " + ", ".join(str(t) for t in tables), file=stream)
    print_digest(results, stream)
    return 0


DIGEST_ROWS = 24


def print_digest(results, stream) -> None:
    """A short table of what the figures show: per point, the settings that vary and the mean
    slowdown of every node, by name (the full table is summary.csv)."""
    nodes = [n for n in nodes_of(results) if any(p.stat(n.metric) for p in results.points)]
    if not nodes:
        return
    metrics = [n.metric for n in nodes]
    settings = varying(results.points, results.config_columns)
    unit = {"_pct": " (%)", "_us": " (us)", "_mbps": " (MB/s)"}
    header = [column_words(c) + next((u for k, u in unit.items() if c.endswith(k)), "")
              for c in settings] + [f"{n.label} slowdown" for n in nodes]
    rows = []
    for p in results.points:
        cells = [style.number(p.config[c]) if isinstance(p.config[c], float) else
                 str(p.config[c]) for c in settings]
        rows.append(cells + [f"{p.mean(m):.3f}" if p.stat(m) else "-" for m in metrics])
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(header)]
    print("what the figures show (mean over repetitions; slowdown = time / isolation time):",
          file=stream)
    print("  " + "  ".join(h.ljust(w) for h, w in zip(header, widths)).rstrip(), file=stream)
    for r in rows[:DIGEST_ROWS]:
        print("  " + "  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip(), file=stream)
    if len(rows) > DIGEST_ROWS:
        print(f"  ... {len(rows) - DIGEST_ROWS} more rows in summary.csv", file=stream)
    print_unregulated(results, stream)


def print_unregulated(results, stream) -> None:
    """What the unregulated co-run (policy none) costs each node, by name, per combination of
    the nodes' workloads: the reference every slowdown figure draws."""
    nodes = [(n, c) for n in nodes_of(results)
             if (c := cell_column(results, n, "unregulated_slowdown"))]
    pairs: dict = {}
    for p in results.points:
        cells = [(n.label if n.several else n.tag, p.stat(c)) for n, c in nodes]
        if any(v for _, v in cells):
            # Every node's workload (rt_workload, nrt_workload, nrt1_workload, ...).
            workloads = {c: v for c, v in p.config.items() if c.endswith("_workload")}
            pairs.setdefault(describe(workloads), [(label, v.mean) for label, v in cells if v])
    if not pairs:
        return
    print("unregulated co-run (the same nodes with policy none; slowdown = time / isolation "
          "time):", file=stream)
    for words, cells in list(pairs.items())[:DIGEST_ROWS]:
        print(f"  {words}: {', '.join(f'{label} {v:.3f}' for label, v in cells)}", file=stream)
    if len(pairs) > DIGEST_ROWS:
        print(f"  ... {len(pairs) - DIGEST_ROWS} more pairs", file=stream)


def summary_metrics(results) -> list:
    """summary.csv's metrics: [(its column name, the points.csv column)], every node's
    (prefixed as in points.csv: nrt_throttle_count is the first nRT node's, also in folders
    that have it only as throttle_count), then the per-point ones."""
    metrics = []
    for n in nodes_of(results):
        for what in NODE_METRICS[n.role]:
            column = cell_column(results, n, what)
            if column:
                metrics.append((n.column(what), column))
    return metrics + [(m, m) for m in POINT_METRICS if m in results.columns]


def write_summary(results, path: Path) -> Path:
    """Per point: configuration, node names, repetitions, and mean/min/max/std of each
    metric."""
    nodes = nodes_of(results)
    names = [(n.column("name"), cell_column(results, n, "name")) for n in nodes]
    metrics = summary_metrics(results)
    header = (["point", *results.config_columns, *(c for c, _ in names), "reps"]
              + [f"{m}_{s}" for m, _ in metrics for s in STATS])
    first_row = {}
    for r in results.rows:
        first_row.setdefault(r["point"], r)
    rows = []
    for p in results.points:
        row = [p.id, *(p.config[c] for c in results.config_columns)]
        row += [first_row[p.id].get(src) if src else n.name for (_, src), n in zip(names, nodes)]
        row.append(p.reps)
        for _, m in metrics:
            st = p.stat(m)
            row += [getattr(st, s) if st else None for s in STATS]
        rows.append(row)
    return write_csv(path, header, rows)


def write_distributions(results, path: Path) -> Path:
    """Per sample kind, sampling mode and sampling period: pooled sample statistics."""
    header = ["kind", "sampling", "sampling_period_us", "points", "samples",
              "min_us", "median_us", "max_us", "mean_us"]
    rows = []
    groups = group_by(results.points, ["sampling", "sampling_period_us"])
    for kind in SAMPLE_KINDS:
        for (mode, period), points in groups.items():
            arrays = [results.samples_of(p.id, kind) for p in points]
            arrays = [a for a in arrays if a.size]
            if not arrays:
                continue
            v = np.concatenate(arrays)
            rows.append([kind, mode, period, len(arrays), int(v.size), float(v.min()),
                         float(np.median(v)), float(v.max()), float(v.mean())])
    return write_csv(path, header, rows)

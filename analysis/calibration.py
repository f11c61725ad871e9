"""Figures of a calibration (what ``rosguard calibrate`` writes): measured vs fitted.

Reads DIR/calibration.json (the measurements and the fit) and DIR/platform.json (the fitted
cost distributions) and draws into DIR/figures/:

- ``calibration_isolation``: time per cache line of each built-in kernel alone, across working
  sets (the cache hierarchy's steps), measured (median, bars: ±1 coefficient of variation) and
  as the fitted model predicts it;
- ``calibration_corun``: every run with co-runners (the bandwidth-latency curve and the co-run
  matrix) as a slowdown over the same kernel alone, measured vs fitted;
- ``calibration_costs``: each middleware / OS cost's measured distribution (histogram) with
  the fitted distribution's median and bounds.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from analysis import style
from analysis.results import InvalidInput

KERNEL_LABELS = {"bandwidth_read": "bandwidth_read (sequential read)",
                 "bandwidth_write": "bandwidth_write (sequential write)",
                 "latency": "latency (pointer chase)"}


def load(folder: Path) -> tuple[dict, dict | None]:
    """calibration.json's document and platform.json's (None when the fit was refused)."""
    cal = folder / "calibration.json"
    if not cal.is_file():
        raise InvalidInput(f"{folder}: not a calibration folder (no calibration.json)")
    try:
        doc = json.loads(cal.read_text())
    except json.JSONDecodeError as e:
        raise InvalidInput(f"{cal}: not JSON ({e})") from None
    if "measurements" not in doc:
        raise InvalidInput(f"{cal}: no 'measurements'")
    platform = folder / "platform.json"
    return doc, json.loads(platform.read_text()) if platform.is_file() else None


def predictions(doc: dict) -> dict[int, float]:
    """Fitted ns per line by index into measurements.runs (empty without a fit)."""
    fit = doc.get("fit") or {}
    return {int(r["index"]): float(r["predicted_ns"]) for r in fit.get("runs", [])
            if r.get("used")}


def corunner_label(run: dict) -> str:
    """'2x bandwidth_read 64 MB' style description of a run's co-runners."""
    counts: dict[str, int] = {}
    for c in run["corunners"]:
        key = f"{c['kernel']} {size_label(c['working_set_kb'])}"
        counts[key] = counts.get(key, 0) + 1
    return ", ".join(f"{n}x {k}" for k, n in counts.items())


def size_label(kb: float) -> str:
    """16 KB, 2 MB, 64 MB."""
    return f"{kb / 1024:g} MB" if kb >= 1024 else f"{kb:g} KB"


def draw_isolation(doc: dict):
    """ns per line vs working set, per kernel, measured and fitted."""
    runs = doc["measurements"]["runs"]
    pred = predictions(doc)
    host = doc["measurements"]["host"]
    kernels = sorted({r["kernel"] for r in runs if not r["corunners"]})
    fig, axes = style.new_figure(1, len(kernels), 4.2 * len(kernels), 3.4)
    for ax, kernel in zip(axes[0], kernels):
        idx = sorted((i for i, r in enumerate(runs) if r["kernel"] == kernel and not r["corunners"]),
                     key=lambda i: runs[i]["working_set_kb"])
        ws = np.array([runs[i]["working_set_kb"] for i in idx])
        ns = np.array([runs[i]["ns_per_line"] for i in idx])
        cv = np.array([runs[i]["cv"] for i in idx])
        ax.errorbar(ws, ns, yerr=ns * cv, fmt="o", color=style.colour(0), capsize=2,
                    label="measured (median, ±CV)")
        fitted = [(runs[i]["working_set_kb"], pred[i]) for i in idx if i in pred]
        if fitted:
            ax.plot(*zip(*fitted), "-x", color=style.colour(1), label="fitted model")
        for name, kb in (("L1d", host["l1d_kb"]), ("L2", host["l2_kb"]),
                         ("L3", host["l3_kb_per_cluster"])):
            if kb > 0:
                ax.axvline(kb, color="0.6", linestyle=":", linewidth=0.8)
                ax.text(kb, ax.get_ylim()[1], name, fontsize=7, color="0.4", ha="right",
                        va="top", rotation=90)
        ax.set_xscale("log", base=2)
        ax.set_xlabel("working set (KB)")
        ax.set_ylabel("time per 64-byte line (ns)")
        ax.set_title(KERNEL_LABELS.get(kernel, kernel), fontsize=9)
        ax.legend(fontsize=7)
    style.finish(fig, f"Isolation of the built-in kernels on {host['hostname']}: measured vs fitted",
                 f"{host['cpu_model']}, {host['cpus']} CPUs, measured {host['date']}")
    return fig


def draw_corun(doc: dict):
    """Slowdown of each run with co-runners over the same kernel and working set alone."""
    runs = doc["measurements"]["runs"]
    pred = predictions(doc)
    alone = {(r["kernel"], r["working_set_kb"]): i for i, r in enumerate(runs) if not r["corunners"]}
    rows = []
    for i, r in enumerate(runs):
        base = alone.get((r["kernel"], r["working_set_kb"]))
        if not r["corunners"] or base is None:
            continue
        measured = r["ns_per_line"] / runs[base]["ns_per_line"]
        fitted = pred[i] / pred[base] if i in pred and base in pred else float("nan")
        rows.append((f"{r['kernel']} {size_label(r['working_set_kb'])}\nwith {corunner_label(r)}",
                     measured, fitted, r["cv"]))
    if not rows:
        raise InvalidInput("the calibration has no run with co-runners")
    fig, axes = style.new_figure(1, 1, 7.5, 0.32 * len(rows) + 1.2)
    ax = axes[0][0]
    y = np.arange(len(rows))
    ax.barh(y - 0.2, [r[1] for r in rows], height=0.4, xerr=[r[1] * r[3] for r in rows],
            color=style.colour(0), label="measured")
    ax.barh(y + 0.2, [r[2] for r in rows], height=0.4, color=style.colour(1), label="fitted model")
    ax.set_yticks(y, [r[0] for r in rows], fontsize=6.5)
    ax.invert_yaxis()
    ax.axvline(1.0, **style.ISOLATION_STYLE)
    ax.set_xlabel(style.SLOWDOWN_LABEL)
    ax.legend(fontsize=7)
    style.finish(fig, "Co-runs: slowdown over the kernel alone, measured vs fitted")
    return fig


def draw_costs(doc: dict, platform: dict | None):
    """Histogram of each cost's samples and the fitted distribution's median / bounds."""
    costs = {k: v for k, v in doc["measurements"]["costs_us"].items() if v}
    if not costs:
        raise InvalidInput("the calibration measured no costs")
    fitted = (platform or {}).get("costs", {})
    fig, axes = style.new_figure((len(costs) + 2) // 3, 3, 11, 2.6)
    flat = axes.flatten()
    for ax, (name, values) in zip(flat, sorted(costs.items())):
        v = np.asarray(values)
        ax.hist(v, bins=40, color=style.colour(0), alpha=0.8)
        ax.axvline(np.median(v), color="k", linewidth=1, label=f"measured p50 {np.median(v):.3g} µs")
        dist = fitted.get(f"{name}_us")
        if dist:
            centre = dist.get("median_us", dist.get("mean_us", dist.get("value_us")))
            if centre is not None:
                ax.axvline(centre, color=style.colour(1), linestyle="--",
                           label=f"fitted {dist['dist']} centre {centre:.3g} µs")
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("µs")
        ax.legend(fontsize=6.5)
    for ax in flat[len(costs):]:
        ax.axis("off")
    style.finish(fig, "Middleware and OS costs: measured samples and the fitted distributions")
    return fig


def run(folder: str) -> int:
    """Draws every figure of a calibration folder into FOLDER/figures."""
    path = Path(folder)
    doc, platform = load(path)
    out = path / "figures"
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for stem, draw in (("calibration_isolation", lambda: draw_isolation(doc)),
                       ("calibration_corun", lambda: draw_corun(doc)),
                       ("calibration_costs", lambda: draw_costs(doc, platform))):
        try:
            written += style.save(draw(), out, stem)
        except InvalidInput as e:
            print(f"skipped {stem}: {e}")
    print(f"wrote {len(written)} files to {out}")
    return 0

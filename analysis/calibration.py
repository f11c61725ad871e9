"""Figures of a calibration (what ``rosguard calibrate`` writes): measured vs fitted.

Reads DIR/calibration.json (the measurements and the fit) and DIR/platform.json (the fitted
cost distributions) and draws into DIR/figures/:

- ``calibration_isolation``: time per cache line of each built-in kernel alone, across working
  sets (the cache hierarchy's steps), measured (median, bars: ±1 coefficient of variation) and
  as the fitted model predicts it;
- ``calibration_corun``: every run with co-runners (the bandwidth-latency curve and the co-run
  matrix) as a slowdown over the same kernel alone, measured vs fitted;
- ``calibration_curves``: the co-runner curves, as co-runners grow (k = 1, 2, 4, ...), per
  co-runner kind: the latency kernel's time per line (the loaded latency), the bandwidth
  kernels' bandwidth per core, and the Mess-style curve (the latency kernel's time per line
  against the co-runners' bandwidth together), each measured (bars: ±1 coefficient of
  variation) and as the fitted model predicts it, and the error of the prediction per k;
  ``calibration_curves.csv`` holds the numbers (the error per k of every curve);
- ``calibration_costs``: each middleware / OS cost's measured distribution (histogram) with
  the fitted distribution's median and bounds.
"""

from __future__ import annotations

import csv
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


MIB = 1024.0 * 1024.0
LINE_BYTES = 64.0


def mbps(ns_per_line: float) -> float:
    """MiB/s of one kernel streaming one 64-byte line every ns_per_line ns."""
    return LINE_BYTES / ns_per_line * 1e9 / MIB


def curves(doc: dict) -> list:
    """The co-runner curves: one row per run whose co-runners are all of one kind, with its
    measured and fitted (NaN without a fit) ns per line and the error (fitted - measured) /
    measured in %: [{'corunner', 'corunner_kb', 'kernel', 'working_set_kb', 'k',
    'measured_ns', 'cv', 'fitted_ns', 'error_pct'}], by co-runner kind, kernel, working set,
    k. The runs alone (k = 0) of the curves' kernels are included: each curve starts there."""
    runs = doc["measurements"]["runs"]
    pred = predictions(doc)
    kinds = {}
    for i, r in enumerate(runs):
        co = {(c["kernel"], c["working_set_kb"]) for c in r["corunners"]}
        if len(co) == 1:
            kinds.setdefault(co.pop(), []).append(i)
    alone = {(r["kernel"], r["working_set_kb"]): i for i, r in enumerate(runs)
             if not r["corunners"]}
    rows = []
    for (ck, ckb), idx in sorted(kinds.items()):
        measured = sorted({(runs[i]["kernel"], runs[i]["working_set_kb"]) for i in idx})
        for kernel, kb in measured:
            series = [i for i in idx if (runs[i]["kernel"], runs[i]["working_set_kb"])
                      == (kernel, kb)]
            if (kernel, kb) in alone:
                series.append(alone[(kernel, kb)])
            for i in sorted(series, key=lambda j: len(runs[j]["corunners"])):
                r = runs[i]
                fitted = pred.get(i, float("nan"))
                rows.append({"corunner": ck, "corunner_kb": ckb, "kernel": kernel,
                             "working_set_kb": kb, "k": len(r["corunners"]),
                             "measured_ns": r["ns_per_line"], "cv": r["cv"],
                             "fitted_ns": fitted,
                             "error_pct": 100.0 * (fitted - r["ns_per_line"]) / r["ns_per_line"]})
    return rows


def _series(rows, corunner, kernel=None):
    """{(kernel, working set): [rows by k]} of one co-runner kind."""
    out: dict = {}
    for r in rows:
        if (r["corunner"], r["corunner_kb"]) == corunner and (kernel is None
                                                              or r["kernel"] == kernel):
            out.setdefault((r["kernel"], r["working_set_kb"]), []).append(r)
    return out


def mess_points(rows, corunner) -> list:
    """The Mess-style curve of one co-runner kind: per k, (the co-runners' bandwidth together,
    the latency kernel's ns per line), measured and fitted, for the latency kernel over the
    co-runners' working set. The co-runners' bandwidth is not measured in the latency kernel's
    run: it is k x the bandwidth of one of them measured with k co-runners of its own kind
    (the same load within one co-runner), so the curve needs that run too.
    [(k, measured MiB/s, measured ns, fitted MiB/s, fitted ns)]."""
    ck, ckb = corunner
    own = {r["k"]: r for r in rows if (r["corunner"], r["corunner_kb"]) == corunner
           and (r["kernel"], r["working_set_kb"]) == (ck, ckb)}
    lat = {r["k"]: r for r in rows if (r["corunner"], r["corunner_kb"]) == corunner
           and (r["kernel"], r["working_set_kb"]) == ("latency", ckb)}
    out = []
    for k in sorted(set(own) & set(lat)):
        if k == 0:
            continue
        bw, lt = own[k], lat[k]
        out.append((k, k * mbps(bw["measured_ns"]), lt["measured_ns"],
                    k * mbps(bw["fitted_ns"]) if np.isfinite(bw["fitted_ns"]) else np.nan,
                    lt["fitted_ns"]))
    return out


def draw_curves(doc: dict):
    """Per co-runner kind (a row): latency vs k, bandwidth per core vs k, the Mess-style
    latency vs the co-runners' bandwidth, and the fitted model's error per k."""
    rows = curves(doc)
    kinds = sorted({(r["corunner"], r["corunner_kb"]) for r in rows})
    kinds = [c for c in kinds if len({r["k"] for r in rows
                                      if (r["corunner"], r["corunner_kb"]) == c}) > 1]
    if not kinds:
        raise InvalidInput("the calibration has no co-runner curve (runs with co-runners of "
                           "one kind)")
    host = doc["measurements"]["host"]
    fitted_any = any(np.isfinite(r["fitted_ns"]) for r in rows)
    fig, axes = style.new_figure(len(kinds), 4, 17.0, 3.3)
    for row, corunner in zip(axes, kinds):
        ck, ckb = corunner
        colours: dict = {}

        def colour(key):
            return colours.setdefault(key, style.colour(len(colours)))

        ax_lat, ax_bw, ax_mess, ax_err = row
        for (kernel, kb), series in _series(rows, corunner).items():
            ks = [r["k"] for r in series]
            meas = np.array([r["measured_ns"] for r in series])
            cv = np.array([r["cv"] for r in series])
            fit = np.array([r["fitted_ns"] for r in series])
            label = f"{kernel} {size_label(kb)}"
            if kernel == "latency":
                ax, y, yfit = ax_lat, meas, fit
            else:
                ax, y, yfit = ax_bw, np.array([mbps(v) for v in meas]),                     np.array([mbps(v) for v in fit])
            # A CV above 1 would take the lower bar below zero: it stops short of zero.
            ax.errorbar(ks, y, yerr=[np.minimum(y * cv, 0.99 * y), y * cv], fmt="o-",
                        color=colour(label), capsize=2,
                        markersize=4, label=f"{label} measured")
            if np.isfinite(yfit).any():
                ax.plot(ks, yfit, "x--", color=colour(label), label=f"{label} fitted")
            errs = [(r["k"], r["error_pct"]) for r in series
                    if r["k"] > 0 and np.isfinite(r["error_pct"])]
            if errs:
                ax_err.plot(*zip(*errs), "o-", color=colour(label), markersize=4, label=label)
        mess = mess_points(rows, corunner)
        if mess:
            ax_mess.plot([m[1] for m in mess], [m[2] for m in mess], "o-", color="k",
                         markersize=4, label="measured")
            for k, x, y, *_ in mess:
                ax_mess.annotate(f"k={k}", (x, y), fontsize=6.5, textcoords="offset points",
                                 xytext=(3, 3))
            fitted = [(m[3], m[4]) for m in mess if np.isfinite(m[3]) and np.isfinite(m[4])]
            if fitted:
                ax_mess.plot(*zip(*fitted), "x--", color=style.colour(1), label="fitted model")
        else:
            ax_mess.text(0.5, 0.5, f"needs latency and {ck} runs over {size_label(ckb)}",
                         transform=ax_mess.transAxes, ha="center", va="center", fontsize=7,
                         color="0.5")
        title = f"with k x {ck} {size_label(ckb)}"
        ax_lat.set_title(f"latency kernel, {title}", fontsize=8.5)
        ax_lat.set_ylabel("ns per line (pointer chase)")
        ax_bw.set_title(f"bandwidth per core, {title}", fontsize=8.5)
        ax_bw.set_ylabel("MiB/s of the measured kernel")
        ax_mess.set_title(f"Mess-style: latency vs co-runners' bandwidth, {title}",
                          fontsize=8.5)
        ax_mess.set_xlabel("co-runners' bandwidth together (MiB/s, est.)")
        ax_mess.set_ylabel(f"latency kernel over {size_label(ckb)}: ns per line")
        ax_err.set_title(f"fitted model's error per k, {title}", fontsize=8.5)
        ax_err.set_ylabel("(fitted − measured) / measured (%)")
        ax_err.axhline(0.0, color="0.5", linewidth=0.8)
        if not fitted_any:
            ax_err.text(0.5, 0.5, "no fit (the calibration refused it)",
                        transform=ax_err.transAxes, ha="center", va="center", fontsize=8,
                        color="0.5")
        for ax in (ax_lat, ax_bw, ax_err):
            ax.set_xlabel("co-runners k")
        for ax in row:
            ax.grid(True, alpha=0.3)
            if ax.get_legend_handles_labels()[0]:
                ax.legend(fontsize=6.5)
    style.finish(fig, "Co-runner curves: latency and bandwidth as co-runners grow, measured vs "
                 "fitted",
                 f"{host['cpu_model']}, {host['cpus']} CPUs, measured {host['date']}. Bars: "
                 "±1 coefficient of variation. Mess-style x axis: k x one co-runner's bandwidth "
                 "measured with k co-runners of its own kind (the co-runners' bandwidth is not "
                 "measured in the latency kernel's run).")
    return fig


def write_curves_csv(doc: dict, path: Path) -> Path:
    """calibration_curves.csv: curves(doc), one row per run (error per k)."""
    rows = curves(doc)
    columns = ["corunner", "corunner_kb", "kernel", "working_set_kb", "k", "measured_ns", "cv",
               "fitted_ns", "error_pct"]
    with path.open("w", newline="") as f:
        writer = csv.writer(f, lineterminator="\n")
        writer.writerow(columns)
        for r in rows:
            writer.writerow(["" if isinstance(r[c], float) and not np.isfinite(r[c])
                             else (f"{r[c]:.6g}" if isinstance(r[c], float) else r[c])
                             for c in columns])
    return path


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
                       ("calibration_curves", lambda: draw_curves(doc)),
                       ("calibration_costs", lambda: draw_costs(doc, platform))):
        try:
            written += style.save(draw(), out, stem)
        except InvalidInput as e:
            print(f"skipped {stem}: {e}")
    if any(r["k"] > 0 for r in curves(doc)):
        written.append(write_curves_csv(doc, out / "calibration_curves.csv"))
    print(f"wrote {len(written)} files to {out}")
    return 0

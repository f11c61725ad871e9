#!/usr/bin/env python3
"""Markdown tables of the middleware costs of a run of scenarios/bench/hw-middleware.json:
the paper's experiments 1-3 on hw, transport inproc vs dds side by side.

    python3 tools/middleware_table.py results/hw-middleware > table.md

Exp. 1: PMC callback (self: group read + publish; external: the controller's read), median.
Exp. 2: self-sampling overhead vs sampling period: the PMC thread's CPU time per period (median
        of samples.csv sampling_overhead) and as a share of the period; nRT slowdown of monitor
        over none (median of the repetitions' ratios).
Exp. 3: activation delay (over-budget sample published / read -> THR entered), p50 and p99 of
        the interval points, per sampling period pooled; and the activation signal (the enable /
        disable published on /rosguard/run/active -> taken by the controller), p50.
"""
import csv
import statistics
import sys
from collections import defaultdict
from pathlib import Path


def pct(values, q):
    v = sorted(values)
    return v[min(len(v) - 1, int(round(q / 100 * (len(v) - 1))))] if v else float("nan")


def main(folder):
    folder = Path(folder)
    points = list(csv.DictReader(open(folder / "points.csv")))
    params = {}
    for r in points:
        params[r["point"]] = (r.get("param:hw.transport") or "inproc", r["sampling"], r["policy"],
                              int(r["sampling_period_us"]))
    samples = defaultdict(list)  # (transport, sampling, policy, period, kind) -> values
    for s in csv.DictReader(open(folder / "samples.csv")):
        samples[params[s["point"]] + (s["kind"],)].append(float(s["value_us"]))
    nrt_time = defaultdict(dict)  # (transport, sampling, policy, period) -> rep -> nrt_time_us
    for r in points:
        if r["nrt_time_us"]:
            nrt_time[params[r["point"]]][r["rep"]] = float(r["nrt_time_us"])
    transports = [t for t in ("inproc", "dds") if any(p[0] == t for p in params.values())]
    periods = sorted({p[3] for p in params.values()})

    def pooled(transport, sampling, policy, kind, period=None):
        out = []
        for (t, s, p, per, k), v in samples.items():
            if (t, s, p, k) == (transport, sampling, policy, kind) and period in (None, per):
                out += v
        return out

    print("**Exp. 1 and 3: PMC callback and activation delay (us, all sampling periods)**\n")
    print("| transport | sampling | PMC callback p50 | activation delay p50 | p99 | max "
          "| activation signal p50 |")
    print("|---|---|---|---|---|---|---|")
    for t in transports:
        for s in ("self", "external"):
            cb = pooled(t, s, "monitor", "pmc_callback") + pooled(t, s, "interval", "pmc_callback")
            ad = pooled(t, s, "interval", "activation_delay")
            sig = sum((pooled(t, s, p, "signal_latency") for p in ("none", "monitor", "interval")),
                      [])
            if not (cb and ad):
                print(f"| {t} | {s} | - | - | - | - | - |")
                continue
            sig_text = f"{statistics.median(sig):.1f}" if sig else "-"  # sim: not modelled
            print(f"| {t} | {s} | {statistics.median(cb):.1f} | {statistics.median(ad):.1f} | "
                  f"{pct(ad, 99):.1f} | {max(ad):.1f} | {sig_text} |")
    print()
    print("**Exp. 2: self-sampling overhead vs sampling period** (PMC thread CPU time per period, "
          "us, and its share of the period; nRT slowdown monitor / none, median of repetitions)\n")
    head = "| transport | " + " | ".join(f"{p} us" for p in periods) + " |"
    print(head)
    print("|---|" + "---|" * len(periods))
    for t in transports:
        cells = []
        for per in periods:
            ov = pooled(t, "self", "monitor", "sampling_overhead", per)
            mon, none = nrt_time[(t, "self", "monitor", per)], nrt_time[(t, "self", "none", per)]
            ratios = [mon[r] / none[r] for r in mon if r in none]
            cell = f"{statistics.median(ov):.1f} ({100 * statistics.median(ov) / per:.1f} %)" if ov else "-"
            if ratios:
                cell += f", x{statistics.median(ratios):.3f}"
            cells.append(cell)
        print(f"| {t} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: middleware_table.py RESULTS_DIR")
    main(sys.argv[1])

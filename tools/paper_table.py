#!/usr/bin/env python3
"""The paper's findings next to what the sim reproduces, computed from results/paper/.

Reads the results of `make reproduce` (one folder per scenario of scenarios/paper/), states each
of the paper's statements as the paper does (an experiment with several statements gets one row
each: 4a-4d, 7a-7d, 8a-8b), the numbers the sim gives for it, and whether it holds, computed here
and never typed in. Where the paper gives no number ("pretty close", "generally"), the reading
used is a named constant below and is written into the statement. tools/sensitivity.py runs the
same checks on variants of the platform. Prints the table, copies one figure per experiment
into the gallery folder, and with --doc replaces that page's block between the markers
<!-- reproduced:begin --> and <!-- reproduced:end --> with the table and the gallery.

    python3 tools/paper_table.py results/paper --gallery docs/figures --doc docs/paper-vs-sim.md
"""

import argparse
import math
import os
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from analysis.markdown import splice  # noqa: E402
from analysis.results import InvalidInput, NotAResultsFolder, load_results  # noqa: E402
# experiment folder -> (figure shown in the gallery, caption)
GALLERY = {
    "table1": ("isolation_table1.png", "Table 1: isolation IPC and bandwidth vs the paper"),
    "exp1-pmc-callback": ("pmc_callback_vs_sampling_period.png", "Exp. 1: PMC callback"),
    "exp2-sampling-overhead": ("sampling_overhead_vs_sampling_period.png",
                               "Exp. 2: sampling overhead"),
    "exp3-activation-delay": ("activation_delay_vs_sampling_period.png",
                              "Exp. 3: activation delay"),
    "exp4-setpoint": ("slowdown_vs_threshold.png", "Exp. 4: setpoint (threshold) sweep"),
    "exp5-sampling-period": ("slowdown_vs_threshold.png", "Exp. 5: sampling period"),
    "exp6-regulation-period": ("slowdown_vs_regulation_period.png", "Exp. 6: regulation period"),
    "exp7-grid": ("rt_nrt_grid_threshold20.png", "Exp. 7: RT x nRT grid at 20 %"),
    "exp8-memguard": ("mechanisms.png",
                      "Exp. 8: ROSGuard (self, external) and MemGuard, per nRT program and threshold"),
}
TABLE1 = {"bandwidth_read": (1.07, 26271.74), "bandwidth_write": (1.61, 25519.15),
          "disparity": (0.83, 1517.16), "mser": (2.16, 3722.43), "sift": (0.58, 232.15),
          "stitch": (0.69, 713.08), "tracking": (3.89, 393.43)}


def select(results, **where):
    """Points whose config matches every (column, value); numbers compared as floats."""
    def match(p):
        for k, v in where.items():
            c = p.config.get(k)
            if isinstance(c, float):
                if not math.isclose(c, float(v)):
                    return False
            elif c != v:
                return False
        return True
    return [p for p in results.points if match(p)]


def mean(results, metric, **where):
    """Mean over the matching points of their mean over repetitions."""
    values = [p.mean(metric) for p in select(results, **where)]
    values = [v for v in values if math.isfinite(v)]
    if not values:
        raise LookupError(f"no {metric} for {where} in {results.folder}")
    return sum(values) / len(values)


def samples(results, kind, **where):
    values = []
    for p in select(results, **where):
        values += list(results.samples_of(p.id, kind))
    return sorted(values)


def median(v):
    return v[len(v) // 2]


# How strictly a finding is read, written out once. A figure of the paper (whose plots are not in
# the text) is read as the words around it say; where the words give no number, the number below
# is this table's reading, stated in the claim column beside the verdict.
NOISE = 0.005          # relative differences below 0.5 % count as "no difference"
HELPS = 0.05           # exp. 5: looser sampling "helps" if it lowers the nRT slowdown by >= 5 %
RT_CLOSE = 1.10        # exp. 7: "pretty close to isolation": RT slowdown at most 1.10
GENERALLY = 0.75       # exp. 7: "generally": at least three quarters of the points
DELAY = 0.01           # exp. 7: 500 us "delays the RT node more": RT slowdown higher by > 1 %
DISTINCT = 0.01        # exp. 8: two nRT slowdowns differ if they differ by >= 1 %
COMPARABLE = 0.10      # exp. 8: "comparable" to MemGuard: mean RT slowdowns within 10 %
# exp. 8: where the paper sees ROSGuard ahead of MemGuard on the nRT node (Sec. V-G: "for
# disparity and mser, the apparent improvement of ROSGuard over MemGuard"); on the others its
# sampling overhead puts it behind.
PAPER_ROSGUARD_AHEAD = {"disparity", "mser"}
# exp. 8: the mechanisms compared, (policy, sampling) as points.csv has them.
ROSGUARD_MODES = (("interval", "self"), ("interval", "external"))
MEMGUARD = ("memguard", "overflow")
PAPER_HIGH_BW = {"bandwidth_read", "bandwidth_write", "disparity"}   # paper, Sec. V-F


def table1(r):
    ipc = max(abs(p.mean("rt_isolation_ipc") / TABLE1[p.config["rt_workload"]][0] - 1)
              for p in r.points) * 100
    bw = max(abs(p.mean("rt_isolation_mbps") / TABLE1[p.config["rt_workload"]][1] - 1)
             for p in r.points) * 100
    return [("Table 1", "IPC and Eq. 1 bandwidth of the seven benchmarks alone (within 3 %)",
             f"largest error over the seven: IPC {ipc:.2f} %, bandwidth {bw:.2f} %",
             ipc < 3 and bw < 3)]


def exp1(r):
    meds, spreads = [], []
    for period in sorted({p.config["sampling_period_us"] for p in r.points}):
        v = samples(r, "pmc_callback", sampling_period_us=period)
        meds.append(median(v))
        spreads.append(v[-1] - v[0])
    return [("1", "PMC callback about 15 us at every sampling period, little variation",
             f"medians {min(meds):.1f}-{max(meds):.1f} us, max - min at most "
             f"{max(spreads):.1f} us",
             13 < min(meds) and max(meds) < 17 and max(spreads) < 5)]


def exp2(r):
    s = {p: mean(r, "nrt_slowdown", sampling="self", sampling_period_us=p)
         for p in (100, 500, 1000, 5000)}
    ext = max(p.mean("nrt_slowdown") for p in select(r, sampling="external"))
    return [("2", "self-sampling slows bandwidth_read 1.059x at 1 ms, little from 500 us up, "
             "excessively below 100 us; external sampling negligible",
             f"self: {s[1000]:.3f} at 1 ms, {s[500]:.3f} at 500 us, {s[5000]:.3f} at 5 ms, "
             f"{s[100]:.2f} at 100 us; external at most {ext:.4f}",
             abs(s[1000] - 1.059) < 0.01 and s[500] < 1.15 and s[100] > 1.5 and ext < 1.005)]


def exp3(r):
    out = {}
    for mode in ("self", "external"):
        v = samples(r, "activation_delay", sampling=mode)
        out[mode] = (median(v), v[0], v[-1])
    (sm, _, sx), (em, emin, ex) = out["self"], out["external"]
    return [("3", "activation delay below 200 us (self) and 100 us (external), nearly constant "
             "across sampling periods, external medians close to the minima",
             f"self: median {sm:.0f} us, max {sx:.0f} us; external: median {em:.0f} us, "
             f"min {emin:.0f} us, max {ex:.0f} us",
             sx < 200 and ex < 100 and em - emin < 0.2 * em)]


def exp4(r):
    def at(w, policy, t, node):
        return mean(r, f"{node}_slowdown", rt_workload=w, policy=policy, threshold_pct=t)
    pairs, trend, mono = [], True, True
    for w in ("bandwidth_read", "mser"):
        rt5, rt30 = at(w, "interval", 5, "rt"), at(w, "interval", 30, "rt")
        n5, n30 = at(w, "interval", 5, "nrt"), at(w, "interval", 30, "nrt")
        m5 = at(w, "monolithic", 5, "nrt")
        pairs.append((w, rt5, rt30, n5, n30, m5))
        trend = trend and rt5 <= rt30 * (1 + NOISE) and n5 >= n30
        mono = mono and m5 > n5
    rows = [("4a", "lower threshold: RT closer to isolation, nRT slower (interval, 5 % vs 30 %, "
             "both pairs)",
             "; ".join(f"{w} pair 5 % -> 30 %: RT {rt5:.2f} -> {rt30:.2f}, nRT {n5:.2f} -> "
                       f"{n30:.2f}" for w, rt5, rt30, n5, n30, _ in pairs), trend),
            ("4b", "monolithic regulation over-penalises the nRT node (nRT slower than interval "
             "at 5 %, both pairs)",
             "; ".join(f"{w} pair nRT at 5 %: monolithic {m5:.2f}, interval {n5:.2f}"
                       for w, _, _, n5, _, m5 in pairs), mono)]
    n5, n10 = (at("bandwidth_read", "interval", t, "nrt") for t in (5, 10))
    rows.append(("4c", "saturation below ~10 %: the nRT node is throttled after one sampling "
                 "period (bandwidth_read pair: nRT slowdown at 5 % and 10 % within 2 %)",
                 f"bandwidth_read pair nRT: {n5:.2f} at 5 %, {n10:.2f} at 10 % "
                 f"({100 * (n5 / n10 - 1):+.1f} %)", abs(n5 / n10 - 1) < 0.02))
    # "saturates the budget even at 30 %": throttled in (nearly) every regulation interval.
    thr30 = select(r, rt_workload="bandwidth_read", policy="interval", threshold_pct=30)[0]
    intervals = thr30.mean("rt_time_us") / thr30.config["regulation_period_us"]
    rows.append(("4d", "bandwidth_read saturates its budget even at 30 % (throttled in at least "
                 "90 % of the regulation intervals)",
                 f"throttled {thr30.mean('throttle_count'):.0f} times in the {intervals:.0f} "
                 f"regulation intervals of its RT job",
                 thr30.mean("throttle_count") >= 0.9 * intervals))
    return rows


def exp5_crossover(drops: dict, helps: float = HELPS):
    """The threshold above which looser sampling helps, from {threshold: relative drop}.

    Returns (t, clean): t is the lowest threshold from which on every threshold's drop is at
    least ``helps`` (None if the highest does not help); clean says that no threshold below t
    helps either, i.e. the thresholds split into "does not help" below and "helps" above.
    """
    ts = sorted(drops)
    t_star = None
    for t in reversed(ts):
        if drops[t] >= helps:
            t_star = t
        else:
            break
    clean = t_star is not None and all(drops[t] < helps for t in ts if t < t_star)
    return t_star, clean


def exp5(r):
    periods = sorted({p.config["sampling_period_us"] for p in r.points})
    ts = sorted({p.config["threshold_pct"] for p in r.points})
    tight, loose = periods[0], periods[-1]

    def nrt(sp, t):
        return mean(r, "nrt_slowdown", sampling_period_us=sp, threshold_pct=t)
    drops = {t: 1 - nrt(loose, t) / nrt(tight, t) for t in ts}
    t_star, clean = exp5_crossover(drops)
    # "only above ~10 %": no help at the thresholds below 10 %, help at those above.
    holds = clean and t_star is not None and 10 <= t_star <= 15 if ts[0] < 10 else False
    where = ("helps at no threshold" if t_star is None else
             f"helps from {t_star:g} % up" + ("" if clean else
                                             ", and also below (no clean split)"))
    low = min(ts)

    def throttled(sp):
        p = select(r, sampling_period_us=sp, threshold_pct=low)
        return 100 * sum(q.mean("throttled_us") / q.mean("rt_time_us") for q in p) / len(p)
    return [("5", f"looser sampling (regulation 5x sampling) lowers the nRT overhead, but only "
             f"for thresholds above ~10 % (helps = nRT slowdown {tight:g} us -> {loose:g} us "
             f"sampling lower by >= {100 * HELPS:.0f} %; expected: no help below 10 %, help above)",
             f"nRT slowdown {tight:g} us -> {loose:g} us: " +
             "; ".join(f"{t:g} %: {nrt(tight, t):.2f} -> {nrt(loose, t):.2f} "
                       f"({-100 * drops[t]:+.0f} %)" for t in ts) +
             f"; looser sampling {where}; at {low:g} % the nRT node is throttled for "
             f"{throttled(tight):.0f} % ({tight:g} us) / {throttled(loose):.0f} % ({loose:g} us) "
             f"of the RT job",
             holds)]


def exp6(r):
    def at(w, period, node):
        return mean(r, f"{node}_slowdown", rt_workload=w, regulation_period_us=period)
    b = [(at("bandwidth_read", p, "nrt"), at("bandwidth_read", p, "rt")) for p in (1000, 5000)]
    m = [at("mser", p, "nrt") for p in (1000, 2000, 3000, 4000, 5000)]
    return [("6", "bandwidth_read pair: longer regulation periods penalise the nRT node (by more "
             "than 10 %) and protect the RT node more; mser pair: little variation (nRT within "
             "0.03)",
             f"bandwidth_read 1 ms -> 5 ms: nRT {b[0][0]:.2f} -> {b[1][0]:.2f}, RT {b[0][1]:.2f} "
             f"-> {b[1][1]:.2f}; mser nRT within {max(m) - min(m):.3f}",
             b[1][0] > 1.1 * b[0][0] and b[1][1] < b[0][1] and max(m) - min(m) < 0.03)]


def high_bandwidth_group(means: dict):
    """Splits {workload: mean nRT slowdown} at the largest ratio between neighbours.

    Returns (high, low, gap): the workloads above the split (the high-impact group), those
    below, and the ratio across the split (smallest of the high / largest of the low).
    """
    order = sorted(means, key=means.get, reverse=True)
    if len(order) < 2:
        return set(order), set(), math.inf
    ratios = [means[order[i]] / means[order[i + 1]] for i in range(len(order) - 1)]
    cut = max(range(len(ratios)), key=ratios.__getitem__)
    return set(order[:cut + 1]), set(order[cut + 1:]), ratios[cut]


def exp7(r):
    rows = []
    # a) RT close to isolation at every point.
    worst = max(r.points, key=lambda p: p.mean("rt_slowdown"))
    above = sum(p.mean("rt_slowdown") > RT_CLOSE for p in r.points)
    wc = worst.config
    rows.append(("7a", f"RT close to isolation in every combination (RT slowdown at most "
                 f"{RT_CLOSE:.2f} at every point)",
                 f"RT slowdown at most {worst.mean('rt_slowdown'):.3f} ({wc['rt_workload']} RT, "
                 f"{wc['nrt_workload']} nRT, {wc['threshold_pct']:g} %, {wc['sampling']} "
                 f"{wc['sampling_period_us']:g} us); {above} of {len(r.points)} points above "
                 f"{RT_CLOSE:.2f}",
                 above == 0))
    # b) the high-bandwidth nRT workloads, by their measured impact.
    workloads = sorted({p.config["nrt_workload"] for p in r.points})
    impact = {w: mean(r, "nrt_slowdown", nrt_workload=w) for w in workloads}
    iso = {w: mean(r, "nrt_isolation_mbps", nrt_workload=w) for w in workloads}
    throttles = {w: max(p.mean("throttle_count") for p in select(r, nrt_workload=w))
                 for w in workloads}
    high, low, gap = high_bandwidth_group(impact)
    order = sorted(workloads, key=impact.get, reverse=True)
    rows.append(("7b", "nRT impact limited except for the high-bandwidth nRT workloads "
                 "bandwidth_read, bandwidth_write and disparity (high group = the nRT workloads "
                 "above the largest ratio gap of the mean nRT slowdowns over the grid)",
                 "mean nRT slowdown (isolation MB/s, most throttles at a point): " +
                 ", ".join(f"{w} {impact[w]:.2f} ({iso[w]:.0f}, {throttles[w]:.0f})"
                           for w in order) +
                 f"; high group {{{', '.join(sorted(high))}}} (gap x{gap:.2f}); the others at "
                 f"most {max((impact[w] for w in low), default=math.nan):.2f}",
                 high == PAPER_HIGH_BW))
    # c) external sampling penalises the nRT node less (same RT, nRT, threshold, 1 ms).
    pairs = []
    for p in select(r, sampling="self", sampling_period_us=1000):
        c = p.config
        twin = select(r, sampling="external", sampling_period_us=1000,
                      rt_workload=c["rt_workload"], nrt_workload=c["nrt_workload"],
                      threshold_pct=c["threshold_pct"])
        if twin:
            pairs.append((p.mean("nrt_slowdown"), twin[0].mean("nrt_slowdown")))
    less = sum(e <= s * (1 + NOISE) for s, e in pairs)
    ms = sum(s for s, _ in pairs) / len(pairs)
    me = sum(e for _, e in pairs) / len(pairs)
    rows.append(("7c", f"external sampling penalises the nRT node less than self-sampling "
                 f"(\"generally\": at {100 * GENERALLY:.0f} % of the points or more, and on "
                 f"average; "
                 f"1 ms / 5 ms)",
                 f"external <= self at {less} of {len(pairs)} points; mean nRT slowdown self "
                 f"{ms:.3f}, external {me:.3f}",
                 bool(pairs) and less >= GENERALLY * len(pairs) and me < ms))
    # d) external 500 us delays the RT node more than external 1 ms at one point at least.
    best = None
    for p in select(r, sampling="external", sampling_period_us=500):
        c = p.config
        twin = select(r, sampling="external", sampling_period_us=1000,
                      rt_workload=c["rt_workload"], nrt_workload=c["nrt_workload"],
                      threshold_pct=c["threshold_pct"])
        if twin:
            d = p.mean("rt_slowdown") / twin[0].mean("rt_slowdown") - 1
            if best is None or d > best[0]:
                best = (d, p, twin[0])
    more = sum(1 for p in select(r, sampling="external", sampling_period_us=500)
               for t in select(r, sampling="external", sampling_period_us=1000,
                               rt_workload=p.config["rt_workload"],
                               nrt_workload=p.config["nrt_workload"],
                               threshold_pct=p.config["threshold_pct"])
               if p.mean("rt_slowdown") > t.mean("rt_slowdown") * (1 + DELAY))
    if best is None:
        rows.append(("7d", "external 500 us sampling occasionally delays the RT node more",
                     "no external 500 us / 1 ms pair in the results", False))
    else:
        d, p, t = best
        c = p.config
        rows.append(("7d", "at 500 us external sampling occasionally delays the RT node more "
                     f"than at 1 ms, with high-bandwidth nRT (at least one point, by more than "
                     f"{100 * DELAY:.0f} %)",
                     f"{more} point(s); largest RT slowdown 500 us vs 1 ms: "
                     f"{p.mean('rt_slowdown'):.3f} vs {t.mean('rt_slowdown'):.3f} "
                     f"({100 * d:+.2f} %; {c['rt_workload']} RT, {c['nrt_workload']} nRT, "
                     f"{c['threshold_pct']:g} %; throttles {p.mean('throttle_count'):.0f} vs "
                     f"{t.mean('throttle_count'):.0f})",
                     more > 0))
    return rows


def mechanism(p):
    return (p.config.get("policy"), p.config.get("sampling"))


def mechanism_name(m):
    return "MemGuard" if m == MEMGUARD else f"ROSGuard {m[1]}"


def exp8(r):
    rows = []
    mechanisms = [m for m in ROSGUARD_MODES + (MEMGUARD,)
                  if any(mechanism(p) == m for p in r.points)]
    # a) the threshold changes the outcome: per (nRT, mechanism), the slowdowns at the
    #    thresholds differ pairwise.
    ts = sorted({p.config["threshold_pct"] for p in r.points})
    series, distinct = [], []
    for w in sorted({p.config["nrt_workload"] for p in r.points}):
        for m in mechanisms:
            v = [mean(r, "nrt_slowdown", nrt_workload=w, policy=m[0], sampling=m[1],
                      threshold_pct=t) for t in ts]
            series.append((w, m, v))
            if all(abs(a / b - 1) >= DISTINCT for i, a in enumerate(v) for b in v[i + 1:]):
                distinct.append(f"{w} {mechanism_name(m)}")
    throttles = sum(p.mean("throttle_count") for p in r.points)
    top = max(r.points, key=lambda p: p.mean("nrt_bandwidth_mbps"))
    budget = top.config["reference_mbps"] * ts[0] / 100
    spread = max(max(v) / min(v) - 1 for _, _, v in series)
    rows.append(("8a", f"the threshold changes the outcome: different nRT slowdowns at "
                 f"{' / '.join(f'{t:g}' for t in ts)} % (pairwise by >= {100 * DISTINCT:.0f} %, "
                 f"for at least half of the nRT x mechanism series)",
                 f"{len(distinct)} of {len(series)} series differ"
                 + (f" ({', '.join(distinct)})" if distinct else "") +
                 f"; largest spread {100 * spread:.1f} %; {throttles:.0f} throttles over all "
                 f"points; highest mean nRT bandwidth {top.mean('nrt_bandwidth_mbps'):.0f} MB/s "
                 f"({top.config['nrt_workload']}) vs the {ts[0]:g} % budget of {budget:.0f} MB/s",
                 2 * len(distinct) >= len(series)))
    ratios = []
    for p in select(r, policy="interval", sampling="self"):
        twin = select(r, policy="interval", sampling="external",
                      nrt_workload=p.config["nrt_workload"],
                      threshold_pct=p.config["threshold_pct"])[0]
        ratios.append(p.mean("nrt_slowdown") / twin.mean("nrt_slowdown"))
    rows.append(("8b", "at 200 us sampling the self-sampling overhead is visible on the nRT "
                 "node; external sampling removes it (self / external nRT slowdown above 1.1 at "
                 "every point)",
                 f"nRT slowdown with self-sampling divided by the one with external sampling "
                 f"(same nRT, same threshold): {min(ratios):.2f}-{max(ratios):.2f}",
                 min(ratios) > 1.1))
    if MEMGUARD not in mechanisms:
        for n, claim in (("8c", "ROSGuard protects the RT node comparably to MemGuard"),
                         ("8d", "ROSGuard's sampling overhead costs the nRT node more than "
                                "MemGuard on the SD-VBS programs other than disparity and mser")):
            rows.append((n, claim, "no MemGuard points (policy memguard) in the results", False))
        return rows
    # c) comparable protection: the mean RT slowdown of each ROSGuard mode over every point
    #    within COMPARABLE of MemGuard's (same nRT workloads, same thresholds).
    rt = {m: mean(r, "rt_slowdown", policy=m[0], sampling=m[1]) for m in mechanisms}
    nrt = {m: mean(r, "nrt_slowdown", policy=m[0], sampling=m[1]) for m in mechanisms}
    off = {m: rt[m] / rt[MEMGUARD] - 1 for m in mechanisms if m != MEMGUARD}
    thr = {m: sum(p.mean("throttle_count") for p in select(r, policy=m[0], sampling=m[1]))
           for m in mechanisms}
    unthrottled = ("; no mechanism throttled at any point, so these are unregulated co-runs "
                   "(the budgets exceed every nRT workload's bandwidth)"
                   if not any(thr.values()) else "")
    rows.append(("8c", "ROSGuard protects the RT node comparably to MemGuard at the same "
                 f"thresholds (mean RT slowdown of each ROSGuard mode within "
                 f"{100 * COMPARABLE:.0f} % of MemGuard's)",
                 "mean RT slowdown " + ", ".join(
                     f"{mechanism_name(m)} {rt[m]:.3f}" for m in mechanisms) +
                 " (" + ", ".join(f"{mechanism_name(m)} {100 * d:+.1f} %"
                                  for m, d in off.items()) + " vs MemGuard); mean nRT "
                 "slowdown " + ", ".join(f"{mechanism_name(m)} {nrt[m]:.3f}"
                                          for m in mechanisms) +
                 "; throttles " + ", ".join(f"{mechanism_name(m)} {thr[m]:.0f}"
                                            for m in mechanisms) + unthrottled,
                 bool(off) and all(abs(d) <= COMPARABLE for d in off.values())))
    # d) where the paper sees ROSGuard behind MemGuard on the nRT node: self-sampling slows it
    #    more than MemGuard at every threshold.
    behind, pairs, worst = 0, 0, None
    for w in sorted({p.config["nrt_workload"] for p in r.points} - PAPER_ROSGUARD_AHEAD):
        for t in ts:
            s_ = mean(r, "nrt_slowdown", nrt_workload=w, policy="interval", sampling="self",
                      threshold_pct=t)
            g = mean(r, "nrt_slowdown", nrt_workload=w, policy=MEMGUARD[0],
                     sampling=MEMGUARD[1], threshold_pct=t)
            pairs += 1
            behind += s_ > g * (1 + NOISE)
            if worst is None or s_ / g < worst[0]:
                worst = (s_ / g, w, t)
    ahead = []
    for w in sorted({p.config["nrt_workload"] for p in r.points} & PAPER_ROSGUARD_AHEAD):
        s_ = mean(r, "nrt_slowdown", nrt_workload=w, policy="interval", sampling="self")
        g = mean(r, "nrt_slowdown", nrt_workload=w, policy=MEMGUARD[0], sampling=MEMGUARD[1])
        ahead.append(f"{w} {s_:.3f} vs {g:.3f}")
    rows.append(("8d", "on the SD-VBS programs other than disparity and mser, ROSGuard's "
                 "self-sampling overhead slows the nRT node more than MemGuard (higher nRT "
                 "slowdown at every threshold)",
                 (f"ROSGuard self above MemGuard in {behind} of {pairs} (nRT, threshold) pairs; "
                  f"lowest ratio {worst[0]:.3f} ({worst[1]} at {worst[2]:g} %)" if worst else
                  "no nRT workload other than disparity and mser in the results")
                 + (f"; disparity / mser (the paper: ROSGuard ahead), self vs MemGuard: "
                    + ", ".join(ahead) if ahead else ""),
                 pairs > 0 and behind == pairs))
    return rows


FINDINGS = (("table1", table1), ("exp1-pmc-callback", exp1),
            ("exp2-sampling-overhead", exp2), ("exp3-activation-delay", exp3),
            ("exp4-setpoint", exp4), ("exp5-sampling-period", exp5),
            ("exp6-regulation-period", exp6), ("exp7-grid", exp7),
            ("exp8-memguard", exp8))

# Why a finding fails in the model, where the numbers beside the verdict do not say it alone.
# Only statements about the model's structure here: every figure is in the table, computed.
WHY = {
    "4c": "Two 2 MB streams on one cluster both miss in the shared L3 (LRU shares it by insertion "
          "rate, and each stream needs more than the other leaves it) and hit in the system-level "
          "cache where the platform has one large enough for both (orin-agx: 4 MB, a guess); the "
          "nRT copy then uses the 5 % budget of an interval within its first 1 ms sample and the "
          "10 % budget just after it, so at 10 % it is throttled a sample later and runs about "
          "twice as long per interval (its throttled time is in the exp. 4 results; sim/README.md, "
          "the memory model).",
    "4d": "Where the bandwidth_read pair is DRAM-bound (no system-level cache, or one too small "
          "for both streams) the nRT copy moves less than the 30 % budget in an interval (its "
          "co-run bandwidth is in the exp. 4 results), so it is not throttled there; that "
          "bandwidth rests on the phase's mlp (an estimate) and the DRAM latency (a guess, swept "
          "over its range in the sensitivity table below).",
    "6": "With the bandwidth_read pair DRAM-bound and not throttled at this threshold (4d), the "
         "regulation period has nothing to change.",
    "5": "In the model the self-sampling cost (one PMC callback plus publishing per sampling "
         "period) is paid by every running nRT node, so a looser sampling period lowers the nRT "
         "slowdown at every threshold; at low thresholds the nRT node is still running for part "
         "of the RT job (the throttled share is in the table), and that part pays the cost.",
    "7a": "The RT slowdown in the model comes from L3, system-level cache and DRAM contention "
          "in the part of each interval the nRT node runs; against a bandwidth_read / _write "
          "nRT node the RT node shares the cluster's L3 with a stream until the throttle (at "
          "15-30 % after one or more 1 ms samples of each interval: the throttled time is in "
          "the exp. 7 results), and LRU gives the stream most of it.",
    "7b": "A workload's nRT impact in the model is its throttling plus the sampling overhead "
          "plus contention. disparity's profile is measured (rosguard profile, a 160 M-"
          "instruction window) with its rates scaled to Table 1's 1517 MB/s; per 2 M-instruction "
          "slice it stays below every grid threshold's budget, so it is not throttled and its "
          "impact stays with the low group. The paper's high-bandwidth disparity would need "
          "per-interval peaks above the budget that the profile's slices do not show.",
    "7d": "At 500 us the nRT node is throttled earlier in each interval than at 1 ms, which "
          "protects the RT node at least as well; the paper's counter-effect (finer sampling "
          "delaying the RT node) needs the throttled core's refill to cost the RT node more than "
          "the earlier throttle saves.",
    "8a": "No nRT workload's bandwidth reaches the lowest threshold's budget in any 1 ms "
          "interval (the throttle count is in the table), so the thresholds give the same run, "
          "under ROSGuard and MemGuard alike. "
          "The scenario follows the paper's setup (RT bandwidth_read, nRT the SD-VBS programs, "
          "20/30/40 % of the total measurable bandwidth, sampling 200 us, regulation 1 ms, self "
          "and external, one cluster); what decides it are the SD-VBS profiles' per-interval "
          "bandwidth peaks.",
}


def load_experiments(results_dir: Path) -> dict:
    """{folder: Results} of every experiment; InvalidInput naming each one that is missing."""
    experiments, missing = {}, []
    for folder, _ in FINDINGS:
        try:
            experiments[folder] = load_results(results_dir / folder)
        except NotAResultsFolder:
            missing.append(folder)
    if missing:
        raise InvalidInput(f"{results_dir}: no results of {', '.join(missing)}; make reproduce "
                           f"runs every experiment (or: rosguard run scenarios/paper/NAME.json "
                           f"--out {results_dir}/NAME)")
    return experiments


def rows_of(experiments: dict):
    """[(exp., claim, reproduced, holds)] for every finding of the loaded experiments."""
    rows = []
    for folder, finding in FINDINGS:
        rows += finding(experiments[folder])
    return rows


def check_rows(results_dir: Path):
    """[(exp., claim, reproduced, holds)] for every finding, computed from the results."""
    return rows_of(load_experiments(results_dir))


def what_ran(experiments: dict) -> str:
    """The table's column title: which backend, platforms and repetitions the results are of."""
    runs = experiments.values()
    backends = sorted({r.backend for r in runs})
    platforms = ", ".join(sorted({r.platform for r in runs}))
    reps = sorted({r.repetitions for r in runs})
    reps_text = f"{reps[0]}" if len(reps) == 1 else f"{reps[0]}-{reps[-1]}"
    who = "the sim reproduces" if backends == ["sim"] else f"measured ({'+'.join(backends)})"
    return f"{who} ({platforms}, {reps_text} repetitions)"


def render(results_dir: Path):
    experiments = load_experiments(results_dir)
    rows = rows_of(experiments)
    lines = [f"| exp. | the paper finds | {what_ran(experiments)} | holds |",
             "|---|---|---|---|"]
    lines += [f"| {n} | {c} | {rep} | {'yes' if ok else '**no**'} |" for n, c, rep, ok in rows]
    failed = [n for n, _, _, ok in rows if not ok]
    notes = [f"- Exp. {n}: {WHY[n]}" for n in failed if n in WHY]
    summary = (f"\n{len(rows) - len(failed)} of {len(rows)} statements hold"
               + (f"; not reproduced: {', '.join(failed)}." if failed else ".") + "\n")
    return "\n".join(lines) + "\n" + summary + ("\n" + "\n".join(notes) + "\n" if notes else "")


def gallery(results_dir: Path, out: Path, page_dir: Path):
    """Copies one figure per experiment into out; the gallery's Markdown for a page in page_dir."""
    out.mkdir(parents=True, exist_ok=True)
    link = Path(os.path.relpath(out.resolve(), page_dir.resolve()))
    lines = []
    for folder, (figure, caption) in GALLERY.items():
        source = results_dir / folder / "figures" / figure
        target = out / f"{folder}.png"
        shutil.copyfile(source, target)
        lines.append(f"**{caption}** (`scenarios/paper/{folder}.json`)\n\n"
                     f"![{caption}]({(link / folder).as_posix()}.png)\n")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("results", type=Path, help="folder with one results folder per experiment")
    ap.add_argument("--gallery", type=Path, help="copy one figure per experiment here")
    ap.add_argument("--doc", type=Path,
                    help="replace this page's block between the reproduced markers")
    args = ap.parse_args()
    try:
        table = render(args.results)
        text = args.doc.read_text() if args.doc else None
        if text is not None:  # the markers checked before a figure is copied
            splice(text, "reproduced", "", str(args.doc))
        section = table
        if args.gallery:
            page_dir = args.doc.parent if args.doc else Path.cwd()
            section += "\n## Gallery\n\n" + gallery(args.results, args.gallery, page_dir)
        if text is not None:
            args.doc.write_text(splice(text, "reproduced", section, str(args.doc)))
    except InvalidInput as e:
        print(e, file=sys.stderr)
        sys.exit(2)
    sys.stdout.write(table)


if __name__ == "__main__":
    main()

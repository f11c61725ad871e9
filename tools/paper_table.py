#!/usr/bin/env python3
"""The paper's findings next to what the sim reproduces, computed from results/paper/.

Reads the results of `make reproduce` (one folder per scenario of scenarios/paper/), states each
experiment's finding as the paper does, the numbers the sim gives for it, and whether the finding
holds (computed here, never typed in). Writes docs/paper-vs-sim.md, copies one figure per
experiment into the gallery folder, and replaces the README's section between the markers
<!-- reproduced:begin --> and <!-- reproduced:end -->.

    python3 tools/paper_table.py results/paper --gallery docs/figures --readme README.md
"""

import argparse
import math
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from analysis.results import load_results  # noqa: E402

BEGIN, END = "<!-- reproduced:begin -->", "<!-- reproduced:end -->"
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
    "exp8-memguard": ("rt_nrt_grid_threshold30.png", "Exp. 8: MemGuard setup at 30 %"),
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


def table1(r):
    ipc = max(abs(p.mean("rt_isolation_ipc") / TABLE1[p.config["rt_workload"]][0] - 1)
              for p in r.points) * 100
    bw = max(abs(p.mean("rt_isolation_mbps") / TABLE1[p.config["rt_workload"]][1] - 1)
             for p in r.points) * 100
    return ("Table 1: IPC and Eq. 1 bandwidth of the seven benchmarks alone",
            f"largest error over the seven: IPC {ipc:.2f} %, bandwidth {bw:.2f} %",
            ipc < 3 and bw < 3)


def exp1(r):
    meds, spreads = [], []
    for period in sorted({p.config["sampling_period_us"] for p in r.points}):
        v = samples(r, "pmc_callback", sampling_period_us=period)
        meds.append(median(v))
        spreads.append(v[-1] - v[0])
    return ("PMC callback about 15 us at every sampling period, little variation",
            f"medians {min(meds):.1f}-{max(meds):.1f} us, max - min at most "
            f"{max(spreads):.1f} us",
            13 < min(meds) and max(meds) < 17 and max(spreads) < 5)


def exp2(r):
    s = {p: mean(r, "nrt_slowdown", sampling="self", sampling_period_us=p)
         for p in (100, 500, 1000, 5000)}
    ext = max(p.mean("nrt_slowdown") for p in select(r, sampling="external"))
    return ("self-sampling slows bandwidth_read 1.059x at 1 ms, little from 500 us up, "
            "excessively below 100 us; external sampling negligible",
            f"self: {s[1000]:.3f} at 1 ms, {s[500]:.3f} at 500 us, {s[5000]:.3f} at 5 ms, "
            f"{s[100]:.2f} at 100 us; external at most {ext:.4f}",
            abs(s[1000] - 1.059) < 0.01 and s[500] < 1.15 and s[100] > 1.5 and ext < 1.005)


def exp3(r):
    out = {}
    for mode in ("self", "external"):
        v = samples(r, "activation_delay", sampling=mode)
        out[mode] = (median(v), v[0], v[-1])
    (sm, _, sx), (em, emin, ex) = out["self"], out["external"]
    return ("activation delay below 200 us (self) and 100 us (external), nearly constant "
            "across sampling periods, external medians close to the minima",
            f"self: median {sm:.0f} us, max {sx:.0f} us; external: median {em:.0f} us, "
            f"min {emin:.0f} us, max {ex:.0f} us",
            sx < 200 and ex < 100 and em - emin < 0.2 * em)


def exp4(r):
    def at(w, policy, t, node):
        return mean(r, f"{node}_slowdown", rt_workload=w, policy=policy, threshold_pct=t)
    lines, ok = [], True
    for w in ("bandwidth_read", "mser"):
        rt5, rt30 = at(w, "interval", 5, "rt"), at(w, "interval", 30, "rt")
        n5, n30 = at(w, "interval", 5, "nrt"), at(w, "interval", 30, "nrt")
        mono = at(w, "monolithic", 5, "nrt")
        lines.append(f"{w} pair, interval 5 % -> 30 %: RT {rt5:.2f} -> {rt30:.2f}, "
                     f"nRT {n5:.2f} -> {n30:.2f}; monolithic at 5 %: nRT {mono:.2f}")
        ok = ok and rt5 <= rt30 * 1.01 and n5 >= n30 and mono > n5
    sat = abs(at("bandwidth_read", "interval", 5, "nrt") / at("bandwidth_read", "interval", 10,
                                                               "nrt") - 1) < 0.02
    thr30 = select(r, rt_workload="bandwidth_read", policy="interval", threshold_pct=30)[0]
    lines.append(f"bandwidth_read throttled {thr30.mean('throttle_count'):.0f} times "
                 f"at 30 % in a {thr30.mean('rt_time_us') / 1000:.0f} ms RT job")
    return ("lower threshold: RT closer to isolation, nRT slower; monolithic over-penalises the "
            "nRT node; saturation below ~10 %; bandwidth_read saturates even at 30 %",
            "; ".join(lines), ok and sat)


def exp5(r):
    def nrt(sp, t):
        return mean(r, "nrt_slowdown", sampling_period_us=sp, threshold_pct=t)
    low = nrt(2000, 5) / nrt(250, 5)
    high = {t: (nrt(250, t), nrt(2000, t)) for t in (15, 30)}
    return ("looser sampling (regulation 5x sampling) lowers the nRT overhead, but only for "
            "thresholds above ~10 %",
            f"nRT slowdown at 250 us -> 2 ms sampling: 5 %: {nrt(250, 5):.2f} -> "
            f"{nrt(2000, 5):.2f}; 15 %: {high[15][0]:.2f} -> {high[15][1]:.2f}; "
            f"30 %: {high[30][0]:.2f} -> {high[30][1]:.2f}",
            abs(low - 1) < 0.05 and all(b < 0.95 * a for a, b in high.values()))


def exp6(r):
    def at(w, period, node):
        return mean(r, f"{node}_slowdown", rt_workload=w, regulation_period_us=period)
    b = [(at("bandwidth_read", p, "nrt"), at("bandwidth_read", p, "rt")) for p in (1000, 5000)]
    m = [at("mser", p, "nrt") for p in (1000, 2000, 3000, 4000, 5000)]
    return ("bandwidth_read pair: longer regulation periods penalise the nRT node and protect "
            "the RT node more; mser pair: little variation",
            f"bandwidth_read 1 ms -> 5 ms: nRT {b[0][0]:.2f} -> {b[1][0]:.2f}, RT {b[0][1]:.2f} "
            f"-> {b[1][1]:.2f}; mser nRT within {max(m) - min(m):.3f}",
            b[1][0] > 1.1 * b[0][0] and b[1][1] < b[0][1] and max(m) - min(m) < 0.03)


def exp7(r):
    high = ("bandwidth_read", "bandwidth_write")
    rt_all = max(p.mean("rt_slowdown") for p in r.points)
    rt_low = max(p.mean("rt_slowdown") for p in r.points if p.config["nrt_workload"] not in high)
    nrt_low = max(p.mean("nrt_slowdown") for p in r.points
                  if p.config["nrt_workload"] in ("sift", "stitch", "tracking"))
    nrt_high = min(p.mean("nrt_slowdown") for p in r.points if p.config["nrt_workload"] in high)
    self_ = mean(r, "nrt_slowdown", sampling="self", sampling_period_us=1000)
    ext = mean(r, "nrt_slowdown", sampling="external", sampling_period_us=1000)
    rt500 = mean(r, "rt_slowdown", sampling="external", sampling_period_us=500,
                 nrt_workload="bandwidth_read")
    rt1000 = mean(r, "rt_slowdown", sampling="external", sampling_period_us=1000,
                  nrt_workload="bandwidth_read")
    holds = rt_all < 1.35 and rt_low < 1.12 and nrt_low < 1.35 and nrt_high > 2 and ext < self_
    return ("RT close to isolation everywhere; nRT impact limited except for high-bandwidth nRT; "
            "external sampling penalises the nRT node less; at 500 us external sampling "
            "occasionally delays the RT node more with high-bandwidth nRT",
            f"RT at most {rt_all:.2f} ({rt_low:.2f} against low-bandwidth nRT); nRT sift / stitch "
            f"/ tracking at most {nrt_low:.2f}, bandwidth_read / _write at least {nrt_high:.2f}; "
            f"mean nRT self {self_:.2f} vs external {ext:.2f}; RT against bandwidth_read, "
            f"external 500 us vs 1 ms: {rt500:.3f} vs {rt1000:.3f}",
            "partly" if holds and rt500 <= rt1000 else holds)


def exp8(r):
    ratios = []
    for p in select(r, sampling="self"):
        twin = select(r, sampling="external", nrt_workload=p.config["nrt_workload"],
                      threshold_pct=p.config["threshold_pct"])[0]
        ratios.append(p.mean("nrt_slowdown") / twin.mean("nrt_slowdown"))
    return ("at 200 us sampling the self-sampling overhead is visible on the nRT node; external "
            "sampling removes it (slowdowns comparable to MemGuard's: MemGuard itself is not "
            "modelled, the comparison is the paper's)",
            f"nRT slowdown with self-sampling divided by the one with external sampling (same nRT, "
            f"same threshold): {min(ratios):.2f}-{max(ratios):.2f}",
            min(ratios) > 1.1)


FINDINGS = (("Table 1", "table1", table1), ("1", "exp1-pmc-callback", exp1),
            ("2", "exp2-sampling-overhead", exp2), ("3", "exp3-activation-delay", exp3),
            ("4", "exp4-setpoint", exp4), ("5", "exp5-sampling-period", exp5),
            ("6", "exp6-regulation-period", exp6), ("7", "exp7-grid", exp7),
            ("8", "exp8-memguard", exp8))

NOTES = {
    "5": "At 5 % the model's nRT node is throttled for less than half of the RT job at every "
         "sampling period (`throttled_us` in results/paper/exp5-sampling-period/points.csv), so "
         "the self-sampling overhead of its running time, which falls with looser sampling, still "
         "shows; and every throttle episode ends in a refill of the L3 lines the RT node evicted "
         "meanwhile (sim/README.md, refill after throttling): 70 episodes at 250 us, 11 at 2 ms. "
         "The drop was 4.5 % (2.01 -> 1.92) before the nRT time compared the same work "
         "(docs/design.md section 6), 5.5 % (1.99 -> 1.88) with it, 14 % with refill (above); "
         "the check itself is unchanged.",
    "7": "Refill after throttling is modelled, but it does not make a finer external sampling "
         "period delay the RT node: with a 5 ms regulation period the nRT node is throttled about "
         "once per period at 500 us and at 1 ms alike (mser RT, bandwidth_read nRT, 20 %: 29 "
         "throttles each), so it refills after about as many REPLENISHes; sampling every 500 us "
         "throttles it earlier, so the RT node is protected at least as well (largest RT "
         "difference 500 us - 1 ms with a bandwidth_read / _write nRT: +0.00003, mser RT at 30 %).",
}


def render(results_dir: Path):
    rows = []
    for number, folder, finding in FINDINGS:
        r = load_results(results_dir / folder)
        claim, reproduced, holds = finding(r)
        verdict = {True: "yes", False: "**no**", "partly": "partly"}[holds]
        rows.append((number, claim, reproduced, verdict))
    lines = ["| exp. | the paper finds | the sim reproduces (orin-agx, 3 repetitions) | holds |",
             "|---|---|---|---|"]
    lines += [f"| {n} | {c} | {rep} | {v} |" for n, c, rep, v in rows]
    notes = [f"- Exp. {n}: {NOTES[n]}" for n, _, _, v in rows if v != "yes" and n in NOTES]
    return "\n".join(lines) + ("\n\n" + "\n".join(notes) if notes else "") + "\n"


def gallery(results_dir: Path, out: Path):
    out.mkdir(parents=True, exist_ok=True)
    lines = []
    for folder, (figure, caption) in GALLERY.items():
        source = results_dir / folder / "figures" / figure
        target = out / f"{folder}.png"
        shutil.copyfile(source, target)
        lines.append(f"**{caption}** (`scenarios/paper/{folder}.json`)\n\n"
                     f"![{caption}](docs/figures/{folder}.png)\n")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("results", type=Path, help="folder with one results folder per experiment")
    ap.add_argument("--gallery", type=Path, help="copy one figure per experiment here")
    ap.add_argument("--readme", type=Path, help="replace the section between the markers")
    args = ap.parse_args()
    table = render(args.results)
    (ROOT / "docs").mkdir(exist_ok=True)
    (ROOT / "docs" / "paper-vs-sim.md").write_text(
        "# The paper's findings, reproduced by the sim backend\n\n"
        "Generated by `make reproduce` (tools/paper_table.py) from `results/paper/`.\n\n" + table)
    section = table
    if args.gallery:
        section += "\n### Gallery\n\n" + gallery(args.results, args.gallery)
    if args.readme:
        text = args.readme.read_text()
        if BEGIN not in text or END not in text:
            sys.exit(f"{args.readme}: markers {BEGIN} / {END} not found")
        head, rest = text.split(BEGIN, 1)
        _, tail = rest.split(END, 1)
        args.readme.write_text(head + BEGIN + "\n" + section + END + tail)
    sys.stdout.write(table)


if __name__ == "__main__":
    main()

"""Writes small, realistic results folders for the analysis tests.

The folders follow docs/design.md section 6 exactly as model/results/results.cpp and
tools/rosguard/run/runner.cpp write them: points.csv with the fixed columns, the extra columns
and one ``param:`` column per sweep key; samples.csv; manifest.json. Values come from a
toy model of regulation (lower threshold: RT closer to isolation, nRT slower; monolithic
penalises nRT more; self-sampling costs ~59 us per sample, external ~2 us) with a little
per-repetition noise, so every figure kind has something sensible to draw.

Each ``*_points()`` function returns the points of one paper experiment; ``write_results``
writes them into a folder.
"""

from __future__ import annotations

import csv
import hashlib
import itertools
import json
import random
from pathlib import Path

import numpy as np

# Written out here, not imported from analysis.results: the fixtures mirror docs/design.md, so a
# drift of the reader's column list fails the tests instead of following it silently.
FIXED_COLUMNS = [
    "point", "rep", "backend", "rt_workload", "nrt_workload", "policy", "sampling", "scope",
    "threshold_pct", "sampling_period_us", "regulation_period_us", "rt_time_us",
    "rt_isolation_us", "rt_slowdown", "nrt_time_us", "nrt_isolation_us", "nrt_slowdown",
    "nrt_bandwidth_mbps", "throttle_count", "throttled_us", "activation_delay_p50_us",
    "activation_delay_max_us", "pmc_callback_p50_us", "rt_isolation_ipc", "rt_isolation_mbps",
    "nrt_isolation_ipc", "nrt_isolation_mbps",
]
EXTRA_COLUMNS = ["platform", "nrt_mode", "rt_jobs", "nrt_runs", "reference_mbps",
                 "sampling_overhead_p50_us", "pmc_callback_max_us", "rt_isolation_n",
                 "rt_isolation_cv", "nrt_isolation_n", "nrt_isolation_cv",
                 "rt_response_p99_us", "rt_response_max_us", "rt_deadline_misses",
                 "signal_latency_p50_us", "signal_to_thr_p50_us"]
# The unregulated co-run (tools/rosguard/run/unregulated.h): written unless write_results gets
# unregulated=False (a folder of an older rosguard, or rosguard run --no-unregulated).
UNREGULATED_COLUMNS = ["rt_unregulated_time_us", "rt_unregulated_slowdown",
                       "nrt_unregulated_time_us", "nrt_unregulated_slowdown"]
RT_JOBS = 3
REFERENCE_MBPS = 26271.74
# workload: (isolation time us, IPC, bandwidth MB/s) -- Table 1 of the paper for IPC / MB/s.
ISOLATION = {
    "bandwidth_read": (20000.0, 1.07, 26271.74),
    "bandwidth_write": (20000.0, 1.61, 25519.15),
    "disparity": (60000.0, 0.83, 1517.16),
    "mser": (30000.0, 2.16, 3722.43),
    "sift": (80000.0, 0.58, 232.15),
    "stitch": (50000.0, 0.69, 713.08),
    "tracking": (40000.0, 3.89, 393.43),
}
BASE = {"rt_workload": "mser", "nrt_workload": "mser", "policy": "interval",
        "sampling": "self", "scope": "core", "threshold_pct": 20, "sampling_period_us": 1000,
        "regulation_period_us": 5000}
# Sweep path -> points.csv column.
PATH_COLUMNS = {
    "nodes.rt[0].workload": "rt_workload",
    "nodes.nrt[0].workload": "nrt_workload",
    "regulation.policy": "policy",
    "regulation.sampling": "sampling",
    "regulation.threshold_pct": "threshold_pct",
    "regulation.sampling_period_us": "sampling_period_us",
    "regulation.regulation_period_us": "regulation_period_us",
}
SAMPLES_PER_RUN = 6


def sweep(base: dict, sweep_lists: dict) -> list:
    """Points of a cartesian sweep: [{'params': {path: value}, **settings}].

    A value may be an object (a sweep over "regulation"): its keys set several columns.
    """
    points = []
    keys = list(sweep_lists)
    for values in itertools.product(*(sweep_lists[k] for k in keys)):
        settings = {**BASE, **base}
        for key, value in zip(keys, values):
            if isinstance(value, dict):
                settings.update(value)
            elif key in PATH_COLUMNS:
                settings[PATH_COLUMNS[key]] = value
        settings["params"] = dict(zip(keys, values))
        points.append(settings)
    return points


def point_id(params: dict) -> str:
    """A stable id of the parameters, in the format rosguard uses (p + 10 hex digits)."""
    text = "".join(f"{k}={json.dumps(v, separators=(',', ':'), sort_keys=True)};"
                   for k, v in params.items())
    return "p" + hashlib.sha1(text.encode()).hexdigest()[:10]


def threshold_points() -> list:
    """Experiment 4: bandwidth_read and mser pairs, thresholds 5-30 %, interval vs monolithic."""
    points = []
    for w in ("bandwidth_read", "mser"):
        points += sweep({"rt_workload": w, "nrt_workload": w},
                        {"nodes.rt[0].workload": [w],
                         "regulation.threshold_pct": [5, 10, 20, 30],
                         "regulation.policy": ["interval", "monolithic"]})
    return points


def regulation_points() -> list:
    """Experiment 6: regulation period 1-5 ms, threshold 30 %, sampling 500 us, two pairs."""
    points = []
    for w in ("mser", "bandwidth_read"):
        points += sweep({"rt_workload": w, "nrt_workload": w, "threshold_pct": 30,
                         "sampling_period_us": 500},
                        {"nodes.rt[0].workload": [w],
                         "regulation.regulation_period_us": [1000, 2000, 3000, 4000, 5000]})
    return points


def sampling_points() -> list:
    """Experiment 5: mser pair, sampling period x threshold, regulation = 5 x sampling."""
    periods = [{"sampling_period_us": sp, "regulation_period_us": 5 * sp}
               for sp in (200, 500, 1000, 2000)]
    return sweep({}, {"regulation": periods, "regulation.threshold_pct": [5, 10, 20, 30]})


def delay_points() -> list:
    """Experiments 1 and 3: bandwidth_read pair, sampling period x self / external."""
    return sweep({"rt_workload": "bandwidth_read", "nrt_workload": "bandwidth_read"},
                 {"regulation.sampling_period_us": [100, 200, 500, 1000, 2000],
                  "regulation.sampling": ["self", "external"]})


def overhead_points() -> list:
    """Experiment 2: bandwidth_read alone (nodes.rt empty), monitor, sampling period sweep."""
    return sweep({"rt_workload": None, "nrt_workload": "bandwidth_read", "policy": "monitor"},
                 {"regulation.sampling_period_us": [50, 100, 200, 500, 1000, 2000],
                  "regulation.sampling": ["self", "external"]})


GRID_CONFIGURATIONS = [
    {"sampling": "self", "sampling_period_us": 1000, "regulation_period_us": 5000},
    {"sampling": "external", "sampling_period_us": 1000, "regulation_period_us": 5000},
    {"sampling": "external", "sampling_period_us": 500, "regulation_period_us": 5000},
]


def grid_points() -> list:
    """Experiment 7 (reduced): RT x nRT workloads x threshold x three configurations."""
    return sweep({}, {"nodes.rt[0].workload": ["mser", "bandwidth_read", "bandwidth_write"],
                      "nodes.nrt[0].workload": ["bandwidth_read", "disparity", "mser", "sift"],
                      "regulation.threshold_pct": [15, 20, 30],
                      "regulation": GRID_CONFIGURATIONS})


def memguard_points() -> list:
    """Experiment 8 (reduced): RT bandwidth_read vs SD-VBS nRT, thresholds 20-40 %."""
    return sweep({"rt_workload": "bandwidth_read", "sampling_period_us": 200,
                  "regulation_period_us": 1000},
                 {"nodes.nrt[0].workload": ["disparity", "mser", "sift"],
                  "regulation.threshold_pct": [20, 30, 40],
                  "regulation.sampling": ["self", "external"]})


def mechanism_points() -> list:
    """Experiment 8 with several mechanisms: ROSGuard self / external against a third policy
    (``memguard``, sampling ``overflow``), bandwidth_read RT vs three SD-VBS nRT, thresholds
    20-40 %."""
    mechanisms = [{"policy": "interval", "sampling": "self"},
                  {"policy": "interval", "sampling": "external"},
                  {"policy": "memguard", "sampling": "overflow"}]
    return sweep({"rt_workload": "bandwidth_read", "sampling_period_us": 200,
                  "regulation_period_us": 1000},
                 {"nodes.nrt[0].workload": ["disparity", "mser", "sift"],
                  "regulation.threshold_pct": [20, 30, 40],
                  "regulation": mechanisms})


def tune_points() -> list:
    """What ``rosguard tune`` leaves: one workload pair, every simulated setting (policy x
    threshold x sampling period)."""
    return sweep({"rt_workload": "mser", "nrt_workload": "bandwidth_read"},
                 {"regulation.policy": ["interval", "monolithic"],
                  "regulation.threshold_pct": [5, 10, 20, 30],
                  "regulation.sampling_period_us": [500, 1000]})


# tune.json as `rosguard tune` writes it (the shape analysis/figures/tradeoff.py reads): the
# best setting by its regulation keys, the runner-up by its point id (filled in by
# write_results), the unregulated co-run by its slowdowns.
TUNE = {
    "rt_slowdown_max": 1.05,
    "objective": "nrt-throughput",
    "best": {"policy": "interval", "regulation.threshold_pct": 10, "sampling_period_us": 500},
    "runner_up": {"point": None},
    "unregulated": {"rt_slowdown": 1.2, "nrt_slowdown": 1.03},
    "simulated_points": 16,
}
TUNE_RUNNER_UP = {"regulation.policy": "interval", "regulation.threshold_pct": 5,
                  "regulation.sampling_period_us": 1000}


def rt_alone_points() -> list:
    """RT node alone (nodes.nrt empty): isolation only, no figure applies."""
    return sweep({"nrt_workload": None, "policy": "none"},
                 {"nodes.rt[0].workload": ["mser", "sift"]})


def _intensity(workload) -> float:
    return ISOLATION[workload][2] / REFERENCE_MBPS if workload else 0.0


def _slowdowns(s: dict) -> tuple:
    """Toy model: (rt slowdown or None, nrt slowdown or None)."""
    rt, nrt, policy = s["rt_workload"], s["nrt_workload"], s["policy"]
    th = s["threshold_pct"] / 100.0
    # us per sample: self-sampling ~59, external ~2, another mode (an overflow interrupt) ~0.5
    sampling_cost = ({"self": 59.0, "external": 2.0}.get(s["sampling"], 0.5)
                     / s["sampling_period_us"])
    if policy == "none":
        sampling_cost = 0.0
    rt_sd = nrt_sd = None
    if rt:
        rt_sd = 1.0 + 0.01 * _intensity(rt)
    if rt and nrt:
        interference = 0.3 * _intensity(nrt) * _intensity(rt) ** 0.5 + 0.02
        excess = max(0.0, _intensity(nrt) - th) / max(_intensity(nrt), 1e-3)
        reg = s["regulation_period_us"] / 5000.0
        if policy == "interval":
            rt_sd = 1.0 + interference * min(1.0, 0.6 * th / max(_intensity(nrt), 0.05)) * reg
            nrt_sd = 1.0 + sampling_cost + 2.0 * excess * reg ** 0.3 + 0.1 * _intensity(rt)
        elif policy == "monolithic":
            rt_sd = 1.0 + interference * 0.2 * th
            nrt_sd = 1.0 + sampling_cost + 4.0 * excess + 0.5
        elif policy == "memguard":   # stopped at once when its budget runs out
            rt_sd = 1.0 + interference * min(1.0, 0.4 * th / max(_intensity(nrt), 0.05)) * reg
            nrt_sd = 1.0 + sampling_cost + 2.5 * excess * reg ** 0.3 + 0.1 * _intensity(rt)
        else:
            rt_sd = 1.0 + interference
            nrt_sd = 1.0 + sampling_cost + 0.2 * _intensity(rt)
    elif nrt:
        nrt_sd = 1.0 + sampling_cost
    return rt_sd, nrt_sd


def _samples(s: dict, rng: random.Random) -> dict:
    """{kind: [values us]} for one run."""
    out = {}
    regulated = s["policy"] in ("interval", "monolithic", "memguard")
    external = s["sampling"] == "external"
    if s["nrt_workload"] and s["policy"] != "none":
        mean, sd = (4.0, 0.5) if external else (15.0, 1.5)
        out["pmc_callback"] = [max(1.0, rng.gauss(mean, sd)) for _ in range(SAMPLES_PER_RUN)]
        mean, sd = (2.0, 0.3) if external else (59.0, 4.0)
        out["sampling_overhead"] = [max(0.5, rng.gauss(mean, sd))
                                    for _ in range(SAMPLES_PER_RUN)]
        out["queue_depth"] = [float(rng.randint(0, 3))]   # an unknown kind, to be ignored
    if regulated and s["rt_workload"] and s["nrt_workload"]:
        mean, sd, floor = (40.0, 8.0, 20.0) if external else (120.0, 25.0, 60.0)
        out["activation_delay"] = [max(floor, rng.gauss(mean, sd))
                                   for _ in range(SAMPLES_PER_RUN)]
    return out


def _us(v) -> str:
    return "" if v is None else f"{v:.3f}"


def _ratio(v) -> str:
    return "" if v is None else f"{v:.6f}"


def _param(v) -> str:
    return v if isinstance(v, str) else json.dumps(v, separators=(",", ":"), sort_keys=True)


def _median(values):
    if not values:
        return None
    v = sorted(values)
    n = len(v)
    return v[n // 2] if n % 2 else 0.5 * (v[n // 2 - 1] + v[n // 2])


def _row(s: dict, pid: str, rep: int, backend: str, rng: random.Random, bias: float):
    rt_sd, nrt_sd = _slowdowns(s)
    # The unregulated co-run: measured once per workload pair (the same value in every
    # repetition and at every setting); a policy-none point carries its own (noisy) values.
    un_rt, un_nrt = (_slowdowns({**s, "policy": "none"}) if s["rt_workload"]
                     and s["nrt_workload"] else (None, None))
    noise = 1.0 + rng.uniform(-0.01, 0.01)
    rt_sd = None if rt_sd is None else 1.0 + (rt_sd - 1.0) * bias * noise
    nrt_sd = None if nrt_sd is None else 1.0 + (nrt_sd - 1.0) * bias * noise
    # A point may fix its figures (``fixed``: rt_slowdown / nrt_slowdown / throttle_count),
    # exactly, in every repetition: for tests of checks on chosen numbers.
    fixed = s.get("fixed", {})
    rt_sd = fixed.get("rt_slowdown", rt_sd)
    nrt_sd = fixed.get("nrt_slowdown", nrt_sd)
    if s["policy"] == "none":
        un_rt, un_nrt = rt_sd, nrt_sd
    rt_iso = ISOLATION.get(s["rt_workload"])
    nrt_iso = ISOLATION.get(s["nrt_workload"])
    samples = _samples(s, rng)
    if rt_iso and rt_sd is not None:  # each job's response time around the mean job time (no rng: other values stay)
        samples["rt_job"] = [rt_sd * rt_iso[0] * (0.98 + 0.02 * j) for j in range(RT_JOBS)]
    jobs = samples.get("rt_job", [])
    delays = samples.get("activation_delay", [])
    callbacks = samples.get("pmc_callback", [])
    throttles = 0 if nrt_sd is None else int(round((nrt_sd - 1.0) * 40))
    throttles = fixed.get("throttle_count", throttles)
    cells = {
        "point": pid, "rep": str(rep), "backend": backend,
        "rt_workload": s["rt_workload"] or "", "nrt_workload": s["nrt_workload"] or "",
        "policy": s["policy"], "sampling": s["sampling"], "scope": s["scope"],
        "threshold_pct": f"{s['threshold_pct']:g}",
        "sampling_period_us": str(s["sampling_period_us"]),
        "regulation_period_us": str(s["regulation_period_us"]),
        "rt_time_us": _us(rt_iso and rt_sd * rt_iso[0]),
        "rt_isolation_us": _us(rt_iso and rt_iso[0]), "rt_slowdown": _ratio(rt_sd),
        "nrt_time_us": _us(nrt_iso and nrt_sd * nrt_iso[0]),
        "nrt_isolation_us": _us(nrt_iso and nrt_iso[0]), "nrt_slowdown": _ratio(nrt_sd),
        "nrt_bandwidth_mbps": _us(nrt_iso and nrt_iso[2] / nrt_sd),
        "throttle_count": "" if nrt_sd is None else str(throttles),
        "throttled_us": "" if nrt_sd is None else _us(throttles * 150.0),
        "activation_delay_p50_us": _us(_median(delays)),
        "activation_delay_max_us": _us(max(delays) if delays else None),
        "pmc_callback_p50_us": _us(_median(callbacks)),
        "rt_isolation_ipc": _ratio(rt_iso and rt_iso[1]),
        "rt_isolation_mbps": _us(rt_iso and rt_iso[2]),
        "nrt_isolation_ipc": _ratio(nrt_iso and nrt_iso[1]),
        "nrt_isolation_mbps": _us(nrt_iso and nrt_iso[2]),
        "platform": "orin-agx", "nrt_mode": "loop" if s["rt_workload"] else "once",
        "rt_jobs": str(RT_JOBS) if rt_iso else "", "nrt_runs": "" if nrt_sd is None else "1.5000",
        "reference_mbps": _us(REFERENCE_MBPS),
        "sampling_overhead_p50_us": _us(_median(samples.get("sampling_overhead", []))),
        "pmc_callback_max_us": _us(max(callbacks) if callbacks else None),
        "rt_isolation_n": "1" if rt_iso else "", "nrt_isolation_n": "1" if nrt_iso else "",
        "rt_response_p99_us": _us(float(np.percentile(jobs, 99)) if jobs else None),
        "rt_response_max_us": _us(max(jobs) if jobs else None),
        "rt_unregulated_time_us": _us(rt_iso and un_rt and un_rt * rt_iso[0]),
        "rt_unregulated_slowdown": _ratio(un_rt if rt_iso else None),
        "nrt_unregulated_time_us": _us(nrt_iso and un_nrt and un_nrt * nrt_iso[0]),
        "nrt_unregulated_slowdown": _ratio(un_nrt if nrt_iso else None),
    }
    for key, value in s["params"].items():
        cells[f"param:{key}"] = _param(value)
    return cells, samples


def write_results(folder, points, *, reps=3, backend="sim", with_samples=True, seed=1,
                  bias=1.0, status="complete", drop=(), references=True,
                  unregulated=True, tune=None) -> Path:
    """Writes manifest.json, points.csv and (optionally) samples.csv; returns the folder.

    ``bias`` scales every slowdown excess (slowdown - 1), e.g. to fake a model that
    over-predicts; ``drop`` lists point indexes to leave out (points missing on one side);
    ``references`` lists the workloads' Table 1 figures in the manifest, as the runner does;
    ``unregulated`` writes the unregulated co-run columns; ``tune`` (a dict) is written as
    tune.json, as ``rosguard tune`` does.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    sweep_keys = list(points[0]["params"]) if points else []
    header = (FIXED_COLUMNS + EXTRA_COLUMNS + (UNREGULATED_COLUMNS if unregulated else [])
              + [f"param:{k}" for k in sweep_keys])
    rng = random.Random(seed)
    rows, sample_rows, manifest_points = [], [], []
    for index, s in enumerate(points):
        pid = point_id(s["params"])
        manifest_points.append({"index": index, "id": pid, "params": s["params"]})
        if index in drop:
            continue
        for rep in range(reps):
            cells, samples = _row(s, pid, rep, backend, rng, bias)
            rows.append([cells.get(c, "") for c in header])
            for kind, values in samples.items():
                sample_rows += [[pid, rep, kind, f"{v:.3f}"] for v in values]
    _write_csv(folder / "points.csv", header, rows)
    if with_samples:
        _write_csv(folder / "samples.csv", ["point", "rep", "kind", "value_us"], sample_rows)
    manifest = {
        "schema_version": 1,
        "tool": {"name": "rosguard", "version": "0.1.0", "git": "test"},
        "scenario_file": "scenarios/test.json",
        "scenario_hash": "0" * 16,
        "scenario": {"given": {}, "expanded": {}, "points": manifest_points},
        "platform": {"origin": "scenarios/platforms/orin-agx.json", "doc": ""},
        "backend": backend, "seed": seed, "repetitions": reps,
        "host": {"hostname": "test", "cpus_online": 2},
        "shard": "0/1", "start_time": "2024-01-01T00:00:00Z",
        "end_time": "2024-01-01T00:01:00Z", "status": status, "warnings": [],
        "fallbacks": [], "facts": {},
        "counts": {"points": len(points), "repetitions": reps, "rows": len(rows)},
    }
    if references:
        manifest["workloads"] = {
            w: {"origin": f"scenarios/workloads/{w}.json",
                "reference": {"ipc": ipc, "mbps": mbps, "source": "paper, Table 1"}}
            for w, (_, ipc, mbps) in ISOLATION.items()}
    (folder / "manifest.json").write_text(json.dumps(manifest, indent=2) + "\n")
    if tune is not None:
        if tune.get("runner_up") == {"point": None}:   # the fixture's runner-up, by its id
            tune = {**tune, "runner_up": {"point": point_id(TUNE_RUNNER_UP)}}
        (folder / "tune.json").write_text(json.dumps(tune, indent=2) + "\n")
    return folder


def _write_csv(path: Path, header, rows) -> None:
    with path.open("w", newline="") as f:
        writer = csv.writer(f, lineterminator="\n")
        writer.writerow(header)
        writer.writerows(rows)

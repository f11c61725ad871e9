#!/usr/bin/python3
"""Predict the hw isolation bandwidth of the built-in bandwidth_read kernel from its profile.

    tools/predict_kernel_host.py [--build build] [--platform scenarios/platforms/vm-2core.json]
        [--calibration docs/calibration/vm-2core/calibration.json] [--working-set-kb 2048]
        [--measure RUNS] [--out DIR]

1. Instructions per line of the kernel's loop: valgrind lackey's instruction counts of
   `rosguard-hw-kernel bandwidth_read KB P` for 2 and 12 passes, differenced (start-up, the
   buffer's pre-fault and exit cancel).
2. Its profile on this host's caches: `rosguard profile --caches L1,L2,L3 --ways ...` (sizes from
   the platform file, ways from sysfs) of 40 passes, the start-up skipped.
3. base_ipc (the sim's IPC with L2 misses served at the unloaded L3 latency): the kernel's
   measured time per line in isolation at the *other* working sets of the same regime (beyond the
   L2, within the L3; the calibration file's bandwidth_read runs alone, the predicted working set
   left out), geometric mean: base_ipc = instructions per line / (ns per line x GHz).
4. The sim's isolation bandwidth of that profile on the host model: `rosguard run` of a sim
   scenario with the profile as its one RT node on the platform file (the run's baseline,
   rt_isolation_mbps), and rosguard-sim-calibrate's steady state beside it.
5. Against the measured isolation bandwidth at the predicted working set (the calibration file's
   median, and with --measure RUNS a fresh median of rosguard-hw-kernel runs now).
Also printed: the prediction with base_ipc from the in-L2 runs (core-bound) instead, which shows
what the model's L3 latency adds (nothing, at an unloaded L3: base_ipc already includes it).
MB/s are MiB/s (2^20 bytes), as Eq. 1 and the calibration's reference.
"""
import argparse
import csv
import json
import math
import os
import re
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MIB = 1048576.0


def lackey_instructions(kernel_bin, kb, passes):
    out = subprocess.run(["valgrind", "--tool=lackey", "--basic-counts=yes", kernel_bin,
                          "bandwidth_read", str(kb), str(passes)],
                         check=True, capture_output=True, text=True).stderr
    m = re.search(r"guest instrs:\s+([\d,]+)", out)
    if not m:
        sys.exit("no instruction count in lackey's output:\n" + out)
    return int(m.group(1).replace(",", ""))


def sysfs_ways():
    ways = {}
    base = "/sys/devices/system/cpu/cpu0/cache"
    for idx in sorted(os.listdir(base)) if os.path.isdir(base) else []:
        d = os.path.join(base, idx)
        try:
            level = open(os.path.join(d, "level")).read().strip()
            kind = open(os.path.join(d, "type")).read().strip()
            w = int(open(os.path.join(d, "ways_of_associativity")).read().strip())
        except (OSError, ValueError):
            continue
        if kind in ("Data", "Unified"):
            ways[int(level)] = w
    return ways


def geomean(xs):
    return math.exp(sum(math.log(x) for x in xs) / len(xs))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--platform", default=os.path.join(ROOT, "scenarios/platforms/vm-2core.json"))
    ap.add_argument("--calibration",
                    default=os.path.join(ROOT, "docs/calibration/vm-2core/calibration.json"))
    ap.add_argument("--working-set-kb", type=int, default=2048)
    ap.add_argument("--measure", type=int, default=0, metavar="RUNS")
    ap.add_argument("--out", default=None, help="keep the profile and workload here")
    args = ap.parse_args()

    kernel_bin = os.path.join(args.build, "hw", "rosguard-hw-kernel")
    rosguard = os.path.join(args.build, "rosguard")
    calibrate = os.path.join(args.build, "sim", "rosguard-sim-calibrate")
    plat = json.load(open(args.platform))
    caches = plat["caches"]
    ghz = plat["cpu"]["freq_mhz"] / 1000.0
    kb = args.working_set_kb
    out = args.out or tempfile.mkdtemp(prefix="predict_kernel.")
    os.makedirs(out, exist_ok=True)

    # 1. Instructions per line.
    lines_per_pass = kb * 1024 // 64
    i2 = lackey_instructions(kernel_bin, kb, 2)
    i12 = lackey_instructions(kernel_bin, kb, 12)
    per_line = (i12 - i2) / (10.0 * lines_per_pass)
    startup = i2 - 2 * per_line * lines_per_pass
    print("instructions per line: %.4f (lackey: %d for 2 passes, %d for 12)" % (per_line, i2, i12))

    # 2. The profile on this host's caches.
    ways = sysfs_ways()
    sizes = [int(caches["l1d_kb"]), int(caches["l2_kb"]), int(caches["l3_kb_per_cluster"])]
    way_list = [ways.get(1, 8), ways.get(2, 8), ways.get(3, 16)]
    profile = os.path.join(out, "bandwidth_read-host.json")
    cmd = [rosguard, "profile", "--quiet", "--out", profile, "--name", "bandwidth_read_profiled",
           "--caches", ",".join(map(str, sizes)), "--ways", ",".join(map(str, way_list)),
           "--skip-instructions", str(int(startup)), "--", kernel_bin, "bandwidth_read", str(kb),
           "40"]
    print("profile: " + " ".join(cmd))
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    doc = json.load(open(profile))
    ph = doc["sim"]["phases"]
    refill_pki = sum(p["fraction"] * p["l2_refill_pki"] for p in ph)
    wb_pki = sum(p["fraction"] * p["l2_wb_pki"] for p in ph)
    print("profile: %.0f instructions, L2 refills %.3f pki, write-backs %.3f pki (%.4f refills "
          "per line), L3 %d KB hit ratio %.4f" %
          (doc["sim"]["instructions"], refill_pki, wb_pki, refill_pki * per_line / 1000.0,
           sizes[2], doc["sim"]["l3_hit"]))

    # 3. Measured time per line, bandwidth_read alone.
    cal = json.load(open(args.calibration))
    runs = {r["working_set_kb"]: r["ns_per_line"] for r in cal["measurements"]["runs"]
            if r["kernel"] == "bandwidth_read" and not r["corunners"]}
    l1, l2, l3 = caches["l1d_kb"], caches["l2_kb"], caches["l3_kb_per_cluster"]
    l3_sets = sorted(w for w in runs if l2 < w <= l3 / 2 and w != kb)
    l2_sets = sorted(w for w in runs if l1 < w <= l2 / 2)
    measured_ns = runs[kb]
    measured_mbps = 64.0 / measured_ns * 1e9 / MIB

    def predict(label, sets):
        t = geomean([runs[w] for w in sets])
        base_ipc = per_line / (t * ghz)
        wl = json.loads(json.dumps(doc))
        for p in wl["sim"]["phases"]:
            p["base_ipc"] = round(base_ipc, 4)
        wl["reference"] = {"mbps": round(measured_mbps, 1),
                           "source": "bandwidth_read %d KB alone, %s (median ns per line)" %
                           (kb, os.path.relpath(args.calibration, ROOT))}
        path = os.path.join(out, "bandwidth_read-host-%s.json" % label)
        json.dump(wl, open(path, "w"), indent=2)
        table = subprocess.run([calibrate, args.platform, path], check=True, capture_output=True,
                               text=True).stdout.splitlines()
        steady = float(table[1].split()[4])
        # A sim run of the profile alone on the host model: its isolation baseline.
        scenario = os.path.join(out, "scenario-%s.json" % label)
        json.dump({"name": "predict-" + label, "backend": "sim",
                   "platform": os.path.abspath(args.platform),
                   "nodes": {"controller": {"core": 0},
                             "rt": [{"name": "rt0", "core": 1, "workload": path}]}},
                  open(scenario, "w"), indent=2)
        results = os.path.join(out, "sim-" + label)
        subprocess.run([rosguard, "run", scenario, "--out", results, "--overwrite"], check=True,
                       capture_output=True, text=True)
        with open(os.path.join(results, "points.csv")) as f:
            row = next(csv.DictReader(f))
        mbps = float(row["rt_isolation_mbps"])
        print("%-6s base_ipc %.4f from %s KB (%.4f ns/line): sim run %.0f MB/s (steady state %.0f) "
              "vs measured %.0f MB/s: %+.1f %%" %
              (label, base_ipc, ",".join("%g" % w for w in sets), t, mbps, steady, measured_mbps,
               100.0 * (mbps / measured_mbps - 1)))
        return mbps

    print("measured at %d KB: %.4f ns/line = %.0f MB/s (%s)" %
          (kb, measured_ns, measured_mbps, os.path.relpath(args.calibration, ROOT)))
    predicted = predict("l3", l3_sets)
    predict("in-l2", l2_sets)
    if args.measure:
        res = subprocess.run([kernel_bin, "bandwidth_read", str(kb), "50", str(args.measure)],
                             check=True, capture_output=True, text=True).stdout
        ns = statistics.median(float(m) for m in re.findall(r"([\d.]+) ns/line", res))
        now = 64.0 / ns * 1e9 / MIB
        print("measured now: median of %d runs %.4f ns/line = %.0f MB/s: prediction %+.1f %%" %
              (args.measure, ns, now, 100.0 * (predicted / now - 1)))
    print("files: " + out)


if __name__ == "__main__":
    main()

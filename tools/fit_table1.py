#!/usr/bin/python3
"""Fit the seven Table 1 workloads (scenarios/workloads/) to the paper's Table 1 on a platform.

    tools/fit_table1.py [--build build] [--platform scenarios/platforms/orin-agx.json]
                        [--rates scaled|measured] [--check] [--strict]

For each workload with a measured profile in scenarios/profiles/NAME.json (written by `rosguard
profile`, see docs/profiling.md), the workload's "sim" section is rebuilt from it
first: instructions, footprint_kb, l3_hit, the phases (fractions, L2 refill and write-back rates,
mlp, mrc) as measured, base_ipc the profile's placeholder. The IsolBench workloads
(bandwidth_read, bandwidth_write), which have no measured profile, keep their sim section.

Then `rosguard-sim-calibrate --fit --write` fits all seven on the platform's memory model:
- every workload: one factor on every phase's base_ipc so that the isolation IPC is Table 1's;
- with --rates scaled (the default): one more factor on every phase's L2 refill and write-back
  rates so that the Eq. 1 MB/s is Table 1's too. For a measured profile that factor is stated in
  its source (with the measured rates it scales); with --rates measured the measured rates stay
  as they are and the MB/s is whatever they give at the Table 1 IPC (the table shows the gap).
Each measured profile's source says what was fitted, to what, on which platform and when.

--check fits into a temporary copy and only prints the table (the workload files stay as they
are). Exit 1 when a fitted workload lands more than 3 % from Table 1 in IPC or (with scaled
rates) MB/s. A measured profile that cannot be fitted is not applied (the workload keeps its
previous sim section; a warning on stderr and a line under the table say why; with --strict the
exit status is then 3). HELD_BACK names the measured profiles
kept out on purpose, with the reason. The fit depends on the sim's memory model: re-run it after the model changes.
"""
import argparse
import datetime
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TABLE1 = ["bandwidth_read", "bandwidth_write", "disparity", "mser", "sift", "stitch", "tracking"]
# Measured profiles kept out of the workloads on purpose (printed with the table). Remove an
# entry to apply it.
HELD_BACK = {}

# Why each SD-VBS run is as long as it is (the sim's `instructions`): kept from the hand-written
# profiles these replace, an estimate of one iteration of the program's main loop on the Orin.
RUN_LENGTH = {
    "disparity": "one iteration of the 5 in the program, estimated at 150 ms in isolation "
                 "(2.74e8 instructions at Table 1's IPC 0.83 and 2.2 GHz).",
    "mser": "one iteration of the 5 in the program, estimated at 120 ms in isolation (5.705e8 "
            "instructions at Table 1's IPC 2.16 and 2.2 GHz).",
    "sift": "one iteration of the 20 in the program, estimated at 500 ms in isolation (6.383e8 "
            "instructions at Table 1's IPC 0.58 and 2.2 GHz).",
    "stitch": "one iteration of the 20 in the program, estimated at 300 ms in isolation "
              "(4.556e8 instructions at Table 1's IPC 0.69 and 2.2 GHz).",
    "tracking": "one iteration of the 20 in the program, estimated at 200 ms in isolation "
                "(1.712e9 instructions at Table 1's IPC 3.89 and 2.2 GHz).",
}


def load(path):
    with open(path) as f:
        return json.load(f)


def save(path, doc):
    with open(path, "w") as f:
        f.write(json.dumps(doc, indent=2) + "\n")


def measured_sim(profile, profile_path, old_sim):
    """The workload's sim section from a measured profile, before the fit. One run's length
    (`instructions`) stays the workload's: a profile covers a window of the program, and the
    experiments' time scales (an RT job's length) hang on the run length."""
    sim = profile["sim"]
    phases = []
    for ph in sim["phases"]:
        p = {k: ph[k] for k in ("fraction", "base_ipc", "l2_refill_pki", "l2_wb_pki") if k in ph}
        for k in ("mlp", "mrc"):
            if k in ph:
                p[k] = ph[k]
        phases.append(p)
    out = {k: sim[k] for k in ("instructions", "footprint_kb", "l3_hit") if k in sim}
    out["instructions"] = old_sim.get("instructions", sim["instructions"])
    out["repeat"] = 1
    out["phases"] = phases
    out["source"] = (
        "Phases, footprint_kb and l3_hit measured: " + os.path.relpath(profile_path, ROOT) +
        " (" + sim["source"] + ") The profile covers %.4g instructions; one run's length "
        "(instructions) is the workload's own, not measured: %s The measured phases' fractions "
        "spread over it." % (sim["instructions"], RUN_LENGTH.get(profile["name"], "")))
    return out


def calibrate(build, platform, files, fit, ipc_only):
    cmd = [os.path.join(build, "sim", "rosguard-sim-calibrate")]
    if fit:
        cmd += ["--fit", "--write"] + (["--ipc-only"] if ipc_only else [])
    out = subprocess.run(cmd + [platform] + files, check=True, capture_output=True, text=True)
    return out.stdout


def parse_table(text):
    rows = {}
    for line in text.splitlines()[1:]:
        f = line.split()
        if len(f) == 8:
            rows[f[0]] = {"ipc": float(f[1]), "ipc_ref": float(f[2]), "ipc_err": float(f[3]),
                          "mbps": float(f[4]), "mbps_ref": float(f[5]),
                          "mbps_err": float(f[6])}
    return rows


def fit_problem(args, doc, tmp):
    """Why the workload's measured sim section cannot be fitted to Table 1 (None when it can)."""
    path = os.path.join(tmp, "trial.json")
    save(path, doc)
    row = parse_table(calibrate(args.build, args.platform, [path], True,
                                args.rates == "measured")).get(doc["name"])
    ok = row is not None and all(math.isfinite(row[k]) for k in ("ipc", "mbps")) and \
        abs(row["ipc_err"]) <= 3 and (args.rates == "measured" or abs(row["mbps_err"]) <= 3)
    if ok:
        return None
    save(path, doc)
    alone = parse_table(calibrate(args.build, args.platform, [path], True, True)).get(doc["name"])
    return ("scaling base_ipc and the L2 rates does not reach Table 1's IPC %g and %g MB/s "
            "together: at those rates the memory stall that the measured l3_hit, footprint_kb and "
            "mlp give is longer than Table 1's cycles per instruction on its own; base_ipc alone gives IPC %.4g and %.0f "
            "MB/s (%+.0f %%)" % (doc["reference"]["ipc"], doc["reference"]["mbps"],
                                 alone["ipc"], alone["mbps"], alone["mbps_err"])
            if args.rates == "scaled" and alone else "the fit lands more than 3 % off")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--platform", default=os.path.join(ROOT, "scenarios/platforms/orin-agx.json"))
    ap.add_argument("--rates", choices=["scaled", "measured"], default="scaled")
    ap.add_argument("--check", action="store_true")
    ap.add_argument("--strict", action="store_true",
                    help="exit 3 when a measured profile cannot be fitted")
    args = ap.parse_args()

    workloads_dir = os.path.join(ROOT, "scenarios", "workloads")
    profiles_dir = os.path.join(ROOT, "scenarios", "profiles")
    tmp = tempfile.mkdtemp(prefix="fit_table1.")
    try:
        files, measured, unfitted = [], {}, {}
        for name in TABLE1:
            doc = load(os.path.join(workloads_dir, name + ".json"))
            ppath = os.path.join(profiles_dir, name + ".json")
            if os.path.exists(ppath) and name in HELD_BACK:
                unfitted[name] = "held back: " + HELD_BACK[name]
            elif os.path.exists(ppath):
                profile = load(ppath)
                trial = json.loads(json.dumps(doc))
                trial["sim"] = measured_sim(profile, ppath, doc.get("sim", {}))
                why = fit_problem(args, trial, tmp)
                if why:
                    # Visible: stderr and the table say so (and --strict exits 3).
                    unfitted[name] = why
                    print("warning: %s: the measured profile %s cannot be fitted on this model (%s);"
                          " the workload keeps its previous sim section" %
                          (name, os.path.relpath(ppath, ROOT), why), file=sys.stderr)
                else:
                    measured[name] = profile
                    doc = trial
            path = os.path.join(tmp, name + ".json")
            save(path, doc)
            files.append(path)
        table = parse_table(calibrate(args.build, args.platform, files, True,
                                      args.rates == "measured"))
        date = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d")
        platform_rel = os.path.relpath(os.path.abspath(args.platform), ROOT)
        print("%-16s %8s %8s %7s %10s %10s %7s  %s" %
              ("workload", "ipc", "ref", "err%", "MB/s", "ref", "err%", "fit"))
        bad = []
        for name, path in zip(TABLE1, files):
            doc = load(path)
            row = table[doc["name"]]
            note = "base_ipc and L2 rates scaled (hand-estimated shape)"
            if name in measured:
                m0 = measured[name]["sim"]["phases"]
                f0 = doc["sim"]["phases"]
                # One factor each over all phases: read it off the phase with the most refills.
                i = max(range(len(m0)), key=lambda k: m0[k]["l2_refill_pki"] * m0[k]["fraction"])
                ipc_factor = f0[i]["base_ipc"] / m0[i]["base_ipc"]
                rate_factor = (f0[i]["l2_refill_pki"] / m0[i]["l2_refill_pki"]
                               if m0[i]["l2_refill_pki"] > 0 else 1.0)
                total = lambda phases: sum(p["fraction"] * (p["l2_refill_pki"] + p["l2_wb_pki"])
                                           for p in phases)
                rates = ("every phase's L2 refill and write-back rates = measured x %.4g "
                         "(measured %.4g L2 refills + write-backs per kilo-instruction over the "
                         "window, fitted %.4g: the Eq. 1 MB/s of the measured rates at the Table 1 "
                         "IPC would be %.4g of Table 1's)" %
                         (rate_factor, total(m0), total(f0), 1.0 / rate_factor)
                         if args.rates == "scaled" else
                         "the L2 refill and write-back rates as measured (%.4g per kilo-instruction"
                         "): Eq. 1 %.0f MB/s against Table 1's %.0f" %
                         (total(m0), row["mbps"], row["mbps_ref"]))
                doc["sim"]["source"] += (
                    " Fitted to the paper's Table 1 (isolation IPC %g, Eq. 1 %g MB/s) by "
                    "tools/fit_table1.py --rates %s (rosguard-sim-calibrate --fit%s on %s) on %s: "
                    "base_ipc = %.4g in every phase (one factor on the profile's placeholder); %s. "
                    "footprint_kb, l3_hit, mlp, the phase fractions and each phase's mrc are as "
                    "measured." %
                    (doc["reference"]["ipc"], doc["reference"]["mbps"], args.rates,
                     " --ipc-only" if args.rates == "measured" else "", platform_rel, date,
                     ipc_factor, rates))
                save(path, doc)
                note = "base_ipc x %.4g, rates x %.4g of measured" % (ipc_factor, rate_factor)
            print("%-16s %8.4f %8.4f %+7.3f %10.2f %10.2f %+7.3f  %s" %
                  (row and doc["name"], row["ipc"], row["ipc_ref"], row["ipc_err"], row["mbps"],
                   row["mbps_ref"], row["mbps_err"], note))
            if abs(row["ipc_err"]) > 3 or (args.rates == "scaled" and abs(row["mbps_err"]) > 3):
                bad.append(name)
        if not args.check:
            # A workload without a measured profile that already meets Table 1 within 0.1 % is
            # left as it is (the fit's last-digit rounding would otherwise change it each time).
            originals = [os.path.join(workloads_dir, n + ".json") for n in TABLE1]
            before = parse_table(calibrate(args.build, args.platform, originals, False, False))
            for name, path in zip(TABLE1, files):
                row = before.get(load(os.path.join(workloads_dir, name + ".json"))["name"])
                if (name not in measured and row and abs(row["ipc_err"]) < 0.1 and
                        abs(row["mbps_err"]) < 0.1):
                    continue
                shutil.copyfile(path, os.path.join(workloads_dir, name + ".json"))
            print("wrote scenarios/workloads/{%s}.json" % ",".join(TABLE1))
        for name, why in unfitted.items():
            print("%s: measured profile not applied: %s" % (name, why))
        if bad:
            print("more than 3 %% from Table 1: %s" % ", ".join(bad), file=sys.stderr)
            return 1
        failed = any(not why.startswith("held back") for why in unfitted.values())
        return 3 if failed and args.strict else 0
    finally:
        shutil.rmtree(tmp)


if __name__ == "__main__":
    sys.exit(main())

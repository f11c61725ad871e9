"""Every nRT node, by name, through the real CLI (sim backend): run, plot and compare.

Usage: nodes_cli_test.py ROSGUARD   (from the source root)

Runs tests/app/fixtures/three-nrt.json (an RT node and three nRT nodes whose names differ from
their workloads) twice: A on the orin-agx platform, B on a copy of it with less DRAM bandwidth
(same points, other slowdowns). Then checks that points.csv names every node and its core (the
first nRT node's throttling under nrt_ too), that `rosguard plot` writes a per-node row for
every point, repetition and node (nodes.csv), summary.csv columns and printed slowdowns per
node, and that `rosguard compare` gives errors per node, by name, and over all nRT nodes.
"""
import atexit
import csv
import json
import os
import shutil
import subprocess
import sys
import tempfile

BIN = sys.argv[1]
FIXTURE = os.path.join("tests", "app", "fixtures", "three-nrt.json")
NODES = [("rt", "detector", 1, "mser"), ("nrt", "reader", 2, "bandwidth_read"),
         ("nrt1", "stereo", 3, "disparity"), ("nrt2", "tracker", 4, "tracking")]
TMP = tempfile.mkdtemp(prefix="nodes-test-")
atexit.register(shutil.rmtree, TMP, True)


def fail(msg):
    print("FAIL: " + msg)
    sys.exit(1)


def cli(*args):
    p = subprocess.run([BIN, *args], capture_output=True, text=True)
    out = p.stdout + p.stderr
    if p.returncode != 0:
        fail(f"rosguard {' '.join(args)} exited {p.returncode}:\n{out}")
    return p.stdout


def table(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def check(condition, msg):
    if not condition:
        fail(msg)


def main():
    a, b = os.path.join(TMP, "a"), os.path.join(TMP, "b")
    cli("run", FIXTURE, "--out", a)
    platform = json.load(open(os.path.join("scenarios", "platforms", "orin-agx.json")))
    platform.pop("$schema", None)
    platform["name"] = "orin-agx-slow-dram"
    platform["memory"]["dram"]["bandwidth_mbps"] *= 0.5
    json.dump(platform, open(os.path.join(TMP, "slow.json"), "w"))
    scenario = json.load(open(FIXTURE))
    scenario.pop("$schema", None)
    scenario["platform"] = os.path.join(TMP, "slow.json")
    json.dump(scenario, open(os.path.join(TMP, "b.json"), "w"))
    cli("run", os.path.join(TMP, "b.json"), "--out", b)

    rows = table(os.path.join(a, "points.csv"))
    check(len(rows) == 8, f"points.csv: {len(rows)} rows, expected 4 points x 2 repetitions")
    for row in rows:
        for key, name, core, workload in NODES:
            check(row[f"{key}_name"] == name and row[f"{key}_core"] == str(core)
                  and row[f"{key}_workload"] == workload,
                  f"points.csv names node {key} {row[key + '_name']} on core "
                  f"{row[key + '_core']}, expected {name} on {core}")
        check(row["nrt_throttle_count"] == row["throttle_count"]
              and row["nrt_throttled_us"] == row["throttled_us"],
              "nrt_throttle_count / nrt_throttled_us differ from throttle_count / throttled_us")
        check(all(row[f"{k}_slowdown"] for k, *_ in NODES), f"a slowdown is empty: {row}")

    figs = os.path.join(a, "figs")
    printed = cli("plot", a, "--out", figs)
    nodes = table(os.path.join(figs, "nodes.csv"))
    check(len(nodes) == 8 * 4, f"nodes.csv: {len(nodes)} rows, expected 8 rows x 4 nodes")
    by = {(r["point"], r["rep"], r["role"], r["node"]): r for r in nodes}
    for row in rows:
        for key, name, core, workload in NODES:
            role = "rt" if key.startswith("rt") else "nrt"
            index = key[len(role):] or "0"
            n = by.get((row["point"], row["rep"], role, index))
            check(n is not None, f"nodes.csv lacks {row['point']} rep {row['rep']} {key}")
            check((n["name"], n["core"], n["workload"]) == (name, str(core), workload),
                  f"nodes.csv row {n} is not node {key} ({name}, core {core})")
            check(float(n["slowdown"]) == float(row[f"{key}_slowdown"]),
                  f"nodes.csv slowdown of {key} differs from points.csv")
            if role == "nrt":
                check(n["throttle_count"] == row[f"{key}_throttle_count"],
                      f"nodes.csv throttle_count of {key} differs from points.csv")
    summary = table(os.path.join(figs, "summary.csv"))
    for key, name, *_ in NODES:
        check(all(r[f"{key}_name"] == name and r[f"{key}_slowdown_mean"] for r in summary),
              f"summary.csv lacks {key}_name / {key}_slowdown_mean")
    for label in ("RT detector slowdown", "nRT0 reader slowdown", "nRT1 stereo slowdown",
                  "nRT2 tracker slowdown"):
        check(label in printed, f"rosguard plot does not print '{label}':\n{printed}")
    check("a panel per nRT node (nRT0 reader, nRT1 stereo, nRT2 tracker)" in printed,
          f"the trade-off figure does not draw a panel per nRT node:\n{printed}")

    out = os.path.join(TMP, "cmp")
    printed = cli("compare", a, b, "--out", out)
    doc = json.load(open(os.path.join(out, "summary.json")))
    for key, name, *_ in NODES:
        check(doc.get(key, {}).get("name") == name and doc[key]["pairs"] == 4,
              f"summary.json node {key}: {doc.get(key)}")
        check(doc[key]["mape_pct"] is not None, f"summary.json: no MAPE for {key}")
    check(doc["overall"]["nrt"]["pairs"] == 12, f"overall nRT pairs {doc['overall']['nrt']}")
    errors = sorted(doc[k]["mape_pct"] for k in ("nrt", "nrt1", "nrt2"))
    check(errors[0] <= doc["overall"]["nrt"]["mape_pct"] <= errors[-1],
          "the overall nRT MAPE is not between the nodes' ones")
    header = table(os.path.join(out, "compare.csv"))[0].keys()
    check({"nrt2_name", "nrt2_slowdown_a", "nrt2_error_pct"} <= set(header),
          f"compare.csv lacks nrt2 columns: {list(header)}")
    lines = printed.splitlines()
    for tag, name in (("RT", "detector"), ("nRT0", "reader"), ("nRT1", "stereo"),
                      ("nRT2", "tracker"), ("nRT", "overall: all 3 nRT nodes")):
        check(any(line.split()[:2] == [tag, "4" if tag != "nRT" else "12"]
                  and line.endswith("  " + name) for line in lines),
              f"rosguard compare prints no row '{tag} ... {name}':\n{printed}")
    print("PASS")


main()

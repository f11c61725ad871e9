#!/usr/bin/env bash
# Issue 52: an rclcpp subscriber (ros2_peer listen, built against ROS 2 Humble) hears an hw run
# with transport dds as ROS 2 topics: /<ns>/rosguard/rt0/active (std_msgs/msg/Bool), /nrt0/pmc
# (rosguard_msgs/msg/PmcSample) and /nrt0/command (rosguard_msgs/msg/Command), decoded by
# rosguard_msgs' own C++ types, with the values the run reports: one true and one false per RT
# job (rt_jobs), one PmcSample of the nRT node (entity 0) per PMC callback (samples.csv), one
# THR command per throttle (points.csv's throttle_count).
# Usage: listen_run.sh ROSGUARD BUILD_DIR SOURCE_DIR DOMAIN
set -euo pipefail
rosguard=$1 build=$2 src=$3 domain=$4
# shellcheck source=ros2_common.sh
source "$src/tests/ros2/ros2_common.sh"
with_tmp
hw_scenario "$tmp/run.json" ros2-listen '{ "name": "rt0", "core": 0, "iterations": 4,
  "workload": { "name": "read_64m", "hw": { "kernel": "bandwidth_read", "working_set_kb": 65536, "passes": 3 } } }'
# Above rosguard's threads, so that it takes each message when it comes ($above).
$above "$peer" listen --ns "$ns" --active rt0 --pmc nrt0 --command nrt0 --seconds 300 \
  >"$tmp/heard.jsonl" 2>"$tmp/listen.err" &
listen_pid=$!
bg=$listen_pid
peer_ready "$tmp/heard.jsonl"
# Without the unregulated co-run: its RT node would publish the same topics from a
# participant of its own, and this test compares with the regulated point's counts.
"$rosguard" run "$tmp/run.json" --out "$tmp/out" --quiet --no-unregulated >"$tmp/run.log" 2>&1 ||
  { cat "$tmp/run.log"; echo "FAIL: rosguard run failed"; exit 1; }
# Reliable topics: what was written reaches the listener; give the last messages a moment.
sleep 1
kill -INT "$listen_pid"
wait "$listen_pid" || true

/usr/bin/python3 - "$tmp/out" "$tmp/heard.jsonl" <<'PY'
import csv, json, sys
out, heard = sys.argv[1], sys.argv[2]
rows = list(csv.DictReader(open(f"{out}/points.csv")))
assert len(rows) == 1, rows
r = rows[0]
kinds = [s["kind"] for s in csv.DictReader(open(f"{out}/samples.csv"))]
msgs = [json.loads(l) for l in open(heard) if l.startswith("{")]
active = [m["data"] for m in msgs if m.get("topic") == "active"]
pmc = [m for m in msgs if m.get("topic") == "pmc"]
cmd_msgs = [m for m in msgs if m.get("topic") == "command"]
cmds = [m["command"] for m in cmd_msgs]
fails = []
jobs = int(r["rt_jobs"])
# Every regulated job of the run's RT node says true at its start and false at its end.
if len(active) != 2 * jobs:
    fails.append(f"{len(active)} active messages for {jobs} RT jobs")
if active != [True, False] * (len(active) // 2):
    fails.append(f"active messages do not alternate true / false: {active[:12]}")
# One PmcSample per PMC callback of the nRT node (samples.csv's pmc_callback).
if len(pmc) != kinds.count("pmc_callback") or not pmc:
    fails.append(f"{len(pmc)} PmcSample heard, {kinds.count('pmc_callback')} PMC callbacks ran")
else:
    if {m["entity"] for m in pmc} != {0}:
        fails.append(f"PmcSample entities {sorted({m['entity'] for m in pmc})}, expected 0 (nrt0)")
    if any(not 1 <= m["count"] <= 8 or len(m["value"]) != m["count"] for m in pmc):
        fails.append("a PmcSample whose count does not match its values")
    # Cumulative counters from one counter group per run: never decreasing between two reads
    # of the same run (a new run may start again from zero).
    stamps = [m["stamp_ns"] for m in pmc]
    if stamps != sorted(stamps):
        fails.append("PmcSample stamps go backwards")
codes = {0: "OFF", 1: "ON", 2: "THR", 3: "REPLENISH", 255: "KEEPALIVE"}
unknown = [c for c in cmds if c not in codes]
if unknown:
    fails.append(f"command codes rosguard_msgs/msg/Command does not define: {unknown[:5]}")
# cause_ns: the stamp of the sample behind a THR; 0 (never negative) when none, as the .msg says.
if any(m["cause_ns"] < 0 for m in cmd_msgs):
    fails.append("a command with a negative cause_ns (rosguard_msgs/msg/Command says 0 when none)")
if any(m["cause_ns"] <= 0 for m in cmd_msgs if m["command"] == 2):
    fails.append("a THR command without the stamp of the sample that caused it")
thr = cmds.count(2)
if thr != int(r["throttle_count"]):
    fails.append(f"{thr} THR commands heard, points.csv throttle_count {r['throttle_count']}")
if thr == 0:
    fails.append("no THR command: the run was not regulated")
counts = {codes.get(c, c): cmds.count(c) for c in sorted(set(cmds))}
print(f"rclcpp heard: {len(active)} active ({active.count(True)} true) for rt_jobs {jobs}; "
      f"{len(pmc)} PmcSample for {kinds.count('pmc_callback')} PMC callbacks; commands {counts}; "
      f"points.csv throttle_count {r['throttle_count']}")
for f in fails:
    print("FAIL:", f)
sys.exit(1 if fails else 0)
PY
echo "PASS"

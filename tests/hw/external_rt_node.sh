#!/usr/bin/env bash
# Issue 13 item 2: an RT node in another process drives regulation over DDS.
# rosguard runs a hw scenario whose RT node has "signal": "topic"; a separate process,
# rosguard-rt-node, runs the critical jobs (64 MB sequential reads on core 0) and publishes
# std_msgs/msg/Bool true / false on <ns>/rosguard/planner/active around each. The nRT node on
# core 1 (the same kernel) must be throttled during those jobs, the point must report the jobs'
# times from the signal stamps and the delay from each active=true to the first THR
# (signal_to_thr); the manifest must say the run's DDS receive sockets are bound to lo. Then:
# without the program, the point fails after hw.dds.signal_timeout_ms,
# naming the node.
# Usage: external_rt_node.sh ROSGUARD RT_NODE SOURCE_DIR
set -euo pipefail
rosguard=$1
rt_node=$2
src=$3
tmp=$(mktemp -d)
run_pid=""
cleanup() {
  [[ -n "$run_pid" ]] && kill "$run_pid" 2>/dev/null || true
  rm -rf "$tmp"
}
trap cleanup EXIT
# A namespace of this test run alone: parallel tests (and other users of the domain) never see
# each other's topics.
ns="/rosguard_test_ext_$$_${RANDOM}"
# Both processes on the loopback interface with unicast discovery (no multicast needed).
export CYCLONEDDS_URI="file://$src/tests/hw/cyclonedds-loopback.xml"

scenario() {  # $1: signal timeout in ms
  cat <<EOF
{
  "\$schema": "$src/scenarios/schema/scenario.schema.json",
  "name": "hw-test-external-rt",
  "platform": "vm-2core",
  "backend": "hw",
  "repetitions": 1,
  "nodes": {
    "controller": { "core": 1 },
    "rt": [ { "name": "planner", "core": 0, "signal": "topic", "iterations": 3,
              "workload": { "name": "bandwidth_read_64m", "hw": { "kernel": "bandwidth_read", "working_set_kb": 65536, "passes": 3 } } } ],
    "nrt": [ { "name": "nrt0", "core": 1,
               "workload": { "name": "bandwidth_read_64m", "hw": { "kernel": "bandwidth_read", "working_set_kb": 65536, "passes": 3 } } } ]
  },
  "regulation": { "policy": "interval", "sampling": "self", "sampling_period_us": 1000,
                  "regulation_period_us": 5000, "threshold_pct": 2 },
  "hw": { "pmc_source": "auto", "watchdog_ms": 100, "baseline_repetitions": 1, "transport": "dds",
          "dds": { "namespace": "$ns", "signal_timeout_ms": $1 } }
}
EOF
}

scenario 60000 >"$tmp/ext.json"
"$rosguard" run "$tmp/ext.json" --out "$tmp/out" --quiet >"$tmp/run.log" 2>&1 &
run_pid=$!
# The program waits for the controller's reader (rosguard measures its baselines first).
"$rt_node" --name planner --ns "$ns" --core 0 --jobs 3 --job-ms 250 --gap-ms 150 \
  --working-set-kb 65536 --wait-ms 60000 --start-delay-ms 100 | tee "$tmp/rt.log"
rc=0
wait "$run_pid" || rc=$?
run_pid=""
cat "$tmp/run.log"
[[ $rc -eq 0 ]] || { echo "FAIL: rosguard run exited $rc"; exit 1; }

/usr/bin/python3 - "$tmp/out" <<'EOF'
import csv, json, statistics, sys
out = sys.argv[1]
rows = list(csv.DictReader(open(f"{out}/points.csv")))
assert len(rows) == 1, rows
r = rows[0]
samples = list(csv.DictReader(open(f"{out}/samples.csv")))
kind = lambda k: [float(s["value_us"]) for s in samples if s["kind"] == k]
manifest = json.load(open(f"{out}/manifest.json"))
text = json.dumps(manifest)
fails = []
if '"transport": "dds"' not in text:
    fails.append("the manifest does not record transport dds")
# The Cyclone configuration selects lo only: the run's receive sockets are bound to it.
if not any("dds_receive_binding" in k for k in text.split('"')) or "bound to lo" not in text:
    fails.append("the manifest does not say the DDS receive sockets are bound to lo")
if r["rt_jobs"] != "3":
    fails.append(f"rt_jobs {r['rt_jobs']}, expected the program's 3 jobs")
# Each job ran 250 ms in the other process; its time comes from the signal stamps.
if not 240e3 <= float(r["rt_time_us"]) <= 400e3:
    fails.append(f"rt_time_us {r['rt_time_us']}: not the program's ~250 ms jobs")
if int(r["throttle_count"]) < 3:
    fails.append(f"throttle_count {r['throttle_count']}: the external jobs did not drive regulation")
to_thr = kind("signal_to_thr")
latency = kind("signal_latency")
if len(latency) != 6:
    fails.append(f"{len(latency)} signal_latency samples, expected 6 (3 jobs x true/false)")
if len(to_thr) < 2:
    fails.append(f"only {len(to_thr)} signal_to_thr samples for 3 regulated jobs")
# The first THR follows the first over-budget sample: within a few sampling periods of the start.
elif not 0 < statistics.median(to_thr) < 50e3:
    fails.append(f"signal_to_thr median {statistics.median(to_thr)} us is not after the signal")
if r["signal_to_thr_p50_us"] == "":
    fails.append("points.csv has no signal_to_thr_p50_us")
print(f"external RT node: rt_time_us {float(r['rt_time_us']):.0f}, throttles {r['throttle_count']}, "
      f"nrt_slowdown {r['nrt_slowdown']}, signal latency p50 {statistics.median(latency):.1f} us, "
      f"active=true -> first THR p50 {statistics.median(to_thr) if to_thr else float('nan'):.1f} us "
      f"(all: {', '.join(f'{v:.0f}' for v in to_thr)})")
for f in fails:
    print("FAIL:", f)
sys.exit(1 if fails else 0)
EOF

# Nobody signals: the point fails after the timeout and says which node it waited for.
scenario 1500 >"$tmp/silent.json"
rc=0
"$rosguard" run "$tmp/silent.json" --out "$tmp/silent" --quiet >"$tmp/silent.log" 2>&1 || rc=$?
cat "$tmp/silent.log"
[[ $rc -eq 1 ]] || { echo "FAIL: a point nobody signalled exited $rc, expected 1"; exit 1; }
grep -q "planner (0 of 3 jobs)" "$tmp/silent.log" ||
  { echo "FAIL: the timeout message does not name the silent node"; exit 1; }
echo "PASS"

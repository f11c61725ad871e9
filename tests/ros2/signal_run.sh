#!/usr/bin/env bash
# Issue 52: an rclcpp node (ros2_peer signal) plays an hw run's RT node: the scenario's RT node
# "planner" says "signal": "topic", and the rclcpp program publishes std_msgs/msg/Bool true /
# false on /<ns>/rosguard/planner/active around each of its 3 jobs. The run takes exactly those
# jobs (rt_jobs 3, one signal_latency sample per message sent), times them from the messages'
# stamps (about the jobs' 300 ms), and regulates the nRT node during them (throttle_count > 0).
# Usage: signal_run.sh ROSGUARD BUILD_DIR SOURCE_DIR DOMAIN
set -euo pipefail
rosguard=$1 build=$2 src=$3 domain=$4
# shellcheck source=ros2_common.sh
source "$src/tests/ros2/ros2_common.sh"
with_tmp
hw_scenario "$tmp/run.json" ros2-signal '{ "name": "planner", "core": 0, "signal": "topic", "iterations": 3,
  "workload": { "name": "read_8m", "hw": { "kernel": "bandwidth_read", "working_set_kb": 8192, "passes": 4 } } }' \
  '"signal_timeout_ms": 60000'
"$rosguard" run "$tmp/run.json" --out "$tmp/out" --quiet >"$tmp/run.log" 2>&1 &
run_pid=$!
bg=$run_pid
# The rclcpp program waits for the run's controller to subscribe (after its baselines).
"$peer" signal --ns "$ns" --name planner --jobs 3 --job-ms 300 --gap-ms 150 --wait-ms 60000 \
  | tee "$tmp/sent.jsonl"
rc=0
wait "$run_pid" || rc=$?
cat "$tmp/run.log"
[[ $rc -eq 0 ]] || { echo "FAIL: rosguard run exited $rc"; exit 1; }
sent=$(count_json "$tmp/sent.jsonl" 'm.get("event") == "sent"')

/usr/bin/python3 - "$tmp/out" "$sent" <<'PY'
import csv, sys
out, sent = sys.argv[1], int(sys.argv[2])
r = list(csv.DictReader(open(f"{out}/points.csv")))[0]
samples = list(csv.DictReader(open(f"{out}/samples.csv")))
latency = [float(s["value_us"]) for s in samples if s["kind"] == "signal_latency"]
fails = []
if sent != 6:
    fails.append(f"the rclcpp node sent {sent} messages, expected 6")
if r["rt_jobs"] != "3":
    fails.append(f"rt_jobs {r['rt_jobs']}: not the rclcpp node's 3 jobs")
if len(latency) != sent:
    fails.append(f"{len(latency)} signal_latency samples for {sent} messages sent")
if not 280e3 <= float(r["rt_time_us"]) <= 450e3:
    fails.append(f"rt_time_us {r['rt_time_us']}: not the rclcpp node's 300 ms jobs")
if int(r["throttle_count"]) < 1:
    fails.append("throttle_count 0: the rclcpp node's jobs did not drive regulation")
print(f"rclcpp RT node: {sent} messages sent, rt_jobs {r['rt_jobs']}, "
      f"{len(latency)} signals taken (latency p50 {sorted(latency)[len(latency)//2]:.0f} us), "
      f"rt_time_us {float(r['rt_time_us']):.0f}, throttle_count {r['throttle_count']}")
for f in fails:
    print("FAIL:", f)
sys.exit(1 if fails else 0)
PY
echo "PASS"

#!/usr/bin/env bash
# Issue 52: ROS 2's graph sees rosguard as it sees its own nodes. An rclcpp program's
# get_topic_names_and_types() lists the guard's topics with their ROS 2 type names
# (std_msgs/msg/Bool, rosguard_msgs/msg/PmcSample, rosguard_msgs/msg/Command), and
# get_node_names() lists the guard (<ns>/rosguard/guard_<name>) and an hw run
# (<ns>/rosguard/run_<scenario>) as nodes, each with its own publishers and subscriptions (what
# `ros2 node info` shows), from the ros_discovery_info they publish as rmw_cyclonedds_cpp does.
# Usage: graph.sh ROSGUARD BUILD_DIR SOURCE_DIR DOMAIN
set -euo pipefail
rosguard=$1 build=$2 src=$3 domain=$4
# shellcheck source=ros2_common.sh
source "$src/tests/ros2/ros2_common.sh"
# shellcheck source=../hw/guard_common.sh
source "$src/tests/hw/guard_common.sh"
fail() { echo "FAIL: $*"; exit 1; }

guard_start ros2graph "\"domain_id\": $domain"
guard_node=$ns/rosguard/guard_ros2graph
"$peer" graph --ns "$ns" --seconds 15 --expect-node "$guard_node" \
  --expect-topic "$ns/rosguard/planner/active" --expect-topic "$ns/rosguard/be/pmc" \
  --expect-topic "$ns/rosguard/be/command" >"$tmp/guard_graph.json" ||
  { cat "$tmp/guard_graph.json"; fail "the guard's node or topics are missing from the ROS 2 graph"; }

# An hw run over DDS, seen while it runs.
hw_scenario "$tmp/run.json" ros2-graph '{ "name": "rt0", "core": 0, "iterations": 20,
  "workload": { "name": "read_8m", "hw": { "kernel": "bandwidth_read", "working_set_kb": 8192, "passes": 4 } } }'
"$rosguard" run "$tmp/run.json" --out "$tmp/out" --quiet >"$tmp/run.log" 2>&1 &
run_pid=$!
extra_pids=$run_pid
run_node=$ns/rosguard/run_ros2_graph
$above "$peer" graph --ns "$ns" --seconds 60 --expect-node "$run_node" \
  --expect-topic "$ns/rosguard/rt0/active" --expect-topic "$ns/rosguard/nrt0/command" \
  >"$tmp/run_graph.json" || { cat "$tmp/run_graph.json" "$tmp/run.log"; fail "the hw run's node is missing from the ROS 2 graph"; }
wait "$run_pid" || { cat "$tmp/run.log"; fail "the hw run failed"; }
extra_pids=""

/usr/bin/python3 - "$tmp/guard_graph.json" "$tmp/run_graph.json" "$ns" <<'PY'
import json, sys
guard, run, ns = json.load(open(sys.argv[1])), json.load(open(sys.argv[2])), sys.argv[3]
fails = []
expect = {f"{ns}/rosguard/planner/active": "std_msgs/msg/Bool",
          f"{ns}/rosguard/be/pmc": "rosguard_msgs/msg/PmcSample",
          f"{ns}/rosguard/be/command": "rosguard_msgs/msg/Command"}
for topic, ty in expect.items():
    if guard["topics"].get(topic) != [ty]:
        fails.append(f"{topic}: types {guard['topics'].get(topic)}, expected [{ty}]")
gn = f"{ns}/rosguard/guard_ros2graph"
info = guard["node_info"][gn]
if set(info["subscribers"]) != {f"{ns}/rosguard/planner/active"}:
    fails.append(f"the guard node's subscriptions: {info['subscribers']}")
if set(info["publishers"]) != {f"{ns}/rosguard/be/pmc", f"{ns}/rosguard/be/command"}:
    fails.append(f"the guard node's publishers: {info['publishers']}")
rn = f"{ns}/rosguard/run_ros2_graph"
rinfo = run["node_info"][rn]
for t in ("rt0/active", "nrt0/pmc", "nrt0/command"):
    if f"{ns}/rosguard/{t}" not in rinfo["publishers"]:
        fails.append(f"the run node does not publish {t}: {rinfo['publishers']}")
print(f"ROS 2 graph: guard node {gn}: publishes {sorted(info['publishers'])}, "
      f"subscribes {sorted(info['subscribers'])}; run node {rn}: {len(rinfo['publishers'])} "
      f"publishers, {len(rinfo['subscribers'])} subscriptions; nodes seen: {run['nodes']}")
for f in fails:
    print("FAIL:", f)
sys.exit(1 if fails else 0)
PY
kill -TERM "$guard_pid"
wait "$guard_pid" || fail "the guard did not stop cleanly"
guard_pid=""
echo "PASS"

# The set-up the ROS 2 interop tests share (tests/ros2/*.sh), sourced after `set -euo pipefail`
# with $build (rosguard's build folder), $src (the source tree) and $domain (this test's own
# DDS domain) set. Skips, saying why, where tools/ros2/workspace.sh found no ROS 2 Humble;
# otherwise sources it (ROS 2's setup files, RMW_IMPLEMENTATION=rmw_cyclonedds_cpp) and sets:
#   $peer    the rclcpp test program (tests/ros2/peer/src/ros2_peer.cpp)
#   $ns      a topic namespace of this run alone
#   ROS_DOMAIN_ID=$domain, CYCLONEDDS_URI: loopback only, unicast discovery (rclcpp's
#            rmw_cyclonedds_cpp and rosguard read the same file)
#   $above   "chrt -f 70" where SCHED_FIFO is allowed, else empty: a prefix that runs a
#            listener above every rosguard thread (the controller's 60). On a host with no CPU
#            to spare, a SCHED_OTHER subscriber is starved while a point's SCHED_FIFO threads
#            run, and takes the point's messages in one burst after it: by then those beyond the
#            writers' history (keep last 10), or sent before it matched, are gone.
# with_tmp: makes $tmp and, on exit, kills every pid in $bg and removes $tmp (the tests that do
#   not take guard_common.sh's).
# hw_scenario FILE NAME RT_NODE [DDS_EXTRA]: writes an hw scenario to FILE: RT_NODE (the JSON of
#   its one RT node, on core 0), nRT node nrt0 (a 64 MB read stream) and the controller on
#   core 1, interval regulation with self-sampling every 1 ms, 5 ms windows, 2 %; transport dds
#   in $ns (DDS_EXTRA: more keys of hw.dds, JSON text).
# peer_ready FILE [SECONDS]: waits until a `ros2_peer listen` writing FILE is subscribed.
# count_json FILE PYTHON_EXPR: how many JSON lines of FILE the expression (on `m`) holds for.
if [[ ! -f $build/ros2/env.sh ]]; then
  why=$(cat "$build/ros2/skipped" 2>/dev/null ||
    echo "tools/ros2/workspace.sh has not run for this build folder (make ros2)")
  echo "SKIPPED: no ROS 2 Humble for this test: $why"
  exit 0
fi
set +u  # ROS 2's setup files read unset variables
# shellcheck source=/dev/null
source "$build/ros2/env.sh"
set -u
export ROS_DOMAIN_ID=$domain
export CYCLONEDDS_URI="file://$src/tests/hw/cyclonedds-loopback.xml"
peer=$build/ros2/install/lib/rosguard_ros2_peer/ros2_peer
[[ -x $peer ]] || { echo "FAIL: the test peer $peer was not built"; exit 1; }
ns="/ros2_test_$$_${RANDOM}"
above=""
chrt -f 70 true 2>/dev/null && above="chrt -f 70"

with_tmp() {
  tmp=$(mktemp -d)
  bg=""
  trap 'for p in $bg; do kill "$p" 2>/dev/null || true; done; rm -rf "$tmp"' EXIT
}

hw_scenario() {
  cat >"$1" <<EOF
{
  "name": "$2",
  "platform": "vm-2core",
  "backend": "hw",
  "repetitions": 1,
  "nodes": {
    "controller": { "core": 1 },
    "rt": [ $3 ],
    "nrt": [ { "name": "nrt0", "core": 1,
               "workload": { "name": "read_64m", "hw": { "kernel": "bandwidth_read", "working_set_kb": 65536, "passes": 3 } } } ]
  },
  "regulation": { "policy": "interval", "sampling": "self", "sampling_period_us": 1000,
                  "regulation_period_us": 5000, "threshold_pct": 2 },
  "hw": { "baseline_repetitions": 1, "transport": "dds", "dds": { "namespace": "$ns"${4:+, $4} } }
}
EOF
}

peer_ready() {
  for _ in $(seq $((${2:-20} * 20))); do
    grep -q '"event": "ready"' "$1" 2>/dev/null && return 0
    sleep 0.05
  done
  echo "FAIL: the rclcpp listener did not start"
  cat "$1"
  exit 1
}

count_json() {
  /usr/bin/python3 -c '
import json, sys
n = 0
for line in open(sys.argv[1]):
    try:
        m = json.loads(line)
    except ValueError:
        continue
    if eval(sys.argv[2]):
        n += 1
print(n)' "$1" "$2"
}

#!/usr/bin/env bash
# The ROS 2 transcripts of docs/dds.md and docs/guard.md, run again: rosguard against rclcpp
# nodes of a real ROS 2 Humble (the test peer of tests/ros2/peer, built by `make ros2`) on the
# loopback interface, domain $ROS_DOMAIN_ID (default 0). Prints each part as Markdown: the
# commands as typed (in the order they were started) and what each printed, shortened where
# marked. Needs 2 CPUs, stress-ng, and root for the guard's SCHED_FIFO; takes about 30 s.
#   1. an hw run (docs/dds/ros2-rt-node.json) whose RT node is an rclcpp program, an
#      rclcpp subscriber of its topics, and the ROS 2 graph during the run;
#   2. `rosguard guard` on a stress-ng, driven by an rclcpp program, its commands heard by one.
# Usage: tools/ros2/demo.sh [BUILD_DIR] [run|guard]...   (default: build, both parts)
set -euo pipefail
cd "$(dirname "$0")/../.."
build=${1:-build}
shift || true
parts=("$@")
((${#parts[@]})) || parts=(run guard)
[[ -f $build/ros2/env.sh ]] || { echo "demo.sh: no $build/ros2/env.sh: run make ros2 first" >&2; exit 2; }
set +u
# shellcheck source=/dev/null
source "$build/ros2/env.sh"
set -u
export CYCLONEDDS_URI="file://$PWD/tests/hw/cyclonedds-loopback.xml"
peer_path=$build/ros2/install/lib/rosguard_ros2_peer/ros2_peer
tmp=$(mktemp -d)
[[ -z ${KEEP:-} ]] || echo "demo.sh: keeping $tmp" >&2
pids=""
trap 'for p in $pids; do kill -9 "$p" 2>/dev/null || true; done; [[ -n ${KEEP:-} ]] || rm -rf "$tmp"' EXIT
# Above rosguard's SCHED_FIFO threads where allowed: on a host with no CPU to spare a subscriber
# under SCHED_OTHER would take a point's messages only after it (docs/dds.md).
above=()
chrt -f 70 true 2>/dev/null && above=(chrt -f 70)
peer=$peer_path
wait_for() {  # FILE PATTERN SECONDS
  for _ in $(seq $(($3 * 20))); do grep -q "$2" "$1" 2>/dev/null && return 0; sleep 0.05; done
  echo "demo.sh: '$2' did not appear in $1" >&2
  cat "$1" >&2
  exit 1
}
# The JSON lines of a listener, shortened: the first N of each topic, then the counts.
summary() {
  /usr/bin/python3 - "$1" "$2" <<'PY'
import collections, json, sys
lines = [l.rstrip("\n") for l in open(sys.argv[1]) if l.startswith("{")]
keep, seen, counts = int(sys.argv[2]), collections.Counter(), collections.Counter()
codes = {0: "OFF", 1: "ON", 2: "THR", 3: "REPLENISH", 255: "KEEPALIVE"}
for l in lines:
    m = json.loads(l)
    key = m.get("topic", "event")
    seen[key] += 1
    if seen[key] <= keep:
        print(l)
    if key == "command":
        counts[f"command {codes.get(m['command'], m['command'])}"] += 1
    elif key != "event":
        counts[key] += 1
print(f"... ({len(lines)} lines: " + ", ".join(f"{v} {k}" for k, v in sorted(counts.items())) + ")")
PY
}
fence() { echo '```'; }

if [[ " ${parts[*]} " == *" run "* ]]; then
  "${above[@]}" "$peer" listen --active planner --pmc nrt0 --command nrt0 --seconds 120 >"$tmp/listen.out" 2>/dev/null &
  pids="$pids $!"
  listen=$!
  wait_for "$tmp/listen.out" '"event": "ready"' 20
  "$build/rosguard" run docs/dds/ros2-rt-node.json --out "$tmp/run" --quiet \
    >"$tmp/run.out" 2>&1 &
  run=$!
  pids="$pids $run"
  "$peer" signal --name planner --jobs 3 --job-ms 300 --gap-ms 200 --wait-ms 60000 \
    --subscribers 2 >"$tmp/signal.out" 2>/dev/null &
  signal=$!
  pids="$pids $signal"
  "${above[@]}" "$peer" graph --seconds 60 --expect-node /rosguard/run_ros2_rt_node >"$tmp/graph.out" 2>/dev/null
  wait "$signal"
  wait "$run" || { cat "$tmp/run.out"; exit 1; }
  sleep 0.5
  kill -INT "$listen"
  wait "$listen" || true
  echo "#### An hw run whose RT node is an rclcpp program"
  fence
  echo "\$ source build/ros2/env.sh      # the Humble of make ros2, with rosguard_msgs and ros2_peer"
  echo "\$ peer=build/ros2/install/lib/rosguard_ros2_peer/ros2_peer"
  echo "\$ chrt -f 70 \$peer listen --active planner --pmc nrt0 --command nrt0 --seconds 120 &"
  echo "\$ build/rosguard run docs/dds/ros2-rt-node.json --out results/ros2-rt-node --quiet &"
  echo "\$ \$peer signal --name planner --jobs 3 --job-ms 300 --gap-ms 200 --wait-ms 60000 --subscribers 2 &"
  cat "$tmp/signal.out"
  echo "\$ chrt -f 70 \$peer graph --seconds 60 --expect-node /rosguard/run_ros2_rt_node | python3 -m json.tool"
  /usr/bin/python3 -m json.tool "$tmp/graph.out"
  echo "\$ wait %2; kill -INT %1      # the listener's lines, shortened:"
  summary "$tmp/listen.out" 3
  cols="rt_jobs rt_time_us throttle_count signal_latency_p50_us signal_to_thr_p50_us"
  pick='import csv, sys; r = next(csv.DictReader(open(sys.argv[1]))); print({k: r[k] for k in sys.argv[2:]})'
  echo "\$ python3 -c '$pick' results/ros2-rt-node/points.csv $cols"
  # shellcheck disable=SC2086
  /usr/bin/python3 -c "$pick" "$tmp/run/points.csv" $cols
  fence
fi

if [[ " ${parts[*]} " == *" guard "* ]]; then
  cat >"$tmp/guard.json" <<'JSON'
{ "name": "demo", "controller": { "core": 0 }, "rt": [ { "name": "planner" } ],
  "nrt": [ { "name": "be", "core": 1 } ],
  "regulation": { "threshold_pct": 10, "reference_mbps": 1000, "regulation_period_us": 10000 } }
JSON
  setsid taskset -c 1 stress-ng --cpu 1 --cpu-method int64 --timeout 60s --quiet &
  stress=$!
  pids="$pids $stress"
  "$build/rosguard" guard "$tmp/guard.json" 2>"$tmp/guard.log" &
  guard=$!
  pids="$pids $guard"
  wait_for "$tmp/guard.log" "regulating pid.*stress-ng-cpu" 20
  "$peer" listen --command be --seconds 60 >"$tmp/cmd.out" 2>/dev/null &
  listen=$!
  pids="$pids $listen"
  wait_for "$tmp/cmd.out" '"event": "ready"' 20
  "$peer" signal --name planner --jobs 2 --job-ms 500 --gap-ms 300 --wait-ms 20000 \
    >"$tmp/gsignal.out" 2>/dev/null
  sleep 0.3
  kill -TERM "$guard"
  wait "$guard" || true
  sleep 0.3
  kill -INT "$listen"
  wait "$listen" || true
  kill -9 -- "-$stress" 2>/dev/null || true
  echo "#### rosguard guard driven by an rclcpp program"
  fence
  echo "\$ cat guard.json"
  cat "$tmp/guard.json"
  echo "\$ setsid taskset -c 1 stress-ng --cpu 1 --cpu-method int64 --timeout 60s --quiet &"
  echo "\$ build/rosguard guard guard.json 2>guard.log &"
  echo "\$ \$peer listen --command be --seconds 60 >commands.jsonl &"
  echo "\$ \$peer signal --name planner --jobs 2 --job-ms 500 --gap-ms 300 --wait-ms 20000"
  cat "$tmp/gsignal.out"
  echo "\$ kill -TERM %2; kill -INT %3"
  echo "\$ grep -v 'regulating pid\|-> THR\|-> ON\|-> REPLENISH\|measuring with\|any process that reaches' guard.log | sed -E 's/^[0-9T:.-]+Z //'"
  grep -v "regulating pid\|-> THR\|-> ON\|-> REPLENISH\|measuring with\|any process that reaches" "$tmp/guard.log" | sed -E 's/^[0-9T:.-]+Z //' 
  echo "\$ cat commands.jsonl      # shortened:"
  summary "$tmp/cmd.out" 4
  fence
fi

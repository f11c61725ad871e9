#!/bin/bash
# What throttling does to a throttled process's middleware threads (docs/guard.md): an rclcpp
# listener (its executor and Cyclone DDS threads) of the guard's pmc topic, on the regulated CPU 1
# beside a stress-ng held to 10 % of 10 ms windows, then on CPU 0; the delay of each message.
# Needs root, 2 CPUs, stress-ng and `make ros2`. Usage: docs/guard/middleware_delay.sh [BUILD]
set -u
src=$(cd "$(dirname "$0")/../.." && pwd)
build=$(cd "${1:-$src/build}" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
set +u; source $build/ros2/env.sh; set -u
peer=$build/ros2/install/lib/rosguard_ros2_peer/ros2_peer
export CYCLONEDDS_URI="file://$src/tests/hw/cyclonedds-loopback.xml"
export ROS_DOMAIN_ID=177
for where in 1 0; do
  ns=/mw$where
  cat > g.json <<J
{ "name": "mw$where", "controller": { "core": 0 }, "rt": [ { "name": "planner" } ],
  "nrt": [ { "name": "be", "core": 1 } ],
  "regulation": { "threshold_pct": 10, "reference_mbps": 1000, "regulation_period_us": 10000 },
  "hw": { "rescan_ms": 50, "pmc_source": "cputime" },
  "activity": { "source": "dds" }, "publish": { "transport": "dds" }, "state_dir": "$work/state",
  "dds": { "namespace": "$ns", "domain_id": 177 } }
J
  setsid taskset -c 1 stress-ng --cpu 1 --cpu-method int64 --timeout 60s --quiet & sp=$!
  $build/rosguard guard g.json 2> log$where & gp=$!
  sleep 1.5
  taskset -c $where $peer listen --ns $ns --pmc be --command be --seconds 30 > heard$where.jsonl & lp=$!
  sleep 2
  ROS_DOMAIN_ID=177 $peer signal --ns $ns --name planner --jobs 4 --job-ms 1000 --gap-ms 500 --wait-ms 20000 > sent$where.jsonl
  sleep 0.5; kill -TERM $gp; wait $gp; kill -INT $lp; wait $lp; kill -9 -- -$sp 2>/dev/null
  python3 - $where <<'PY'
import json,sys
w=sys.argv[1]
lat=[]
for l in open(f'heard{w}.jsonl'):
    try: m=json.loads(l)
    except: continue
    if m.get('topic')=='pmc': lat.append((int(m['t_ns'])-int(m['stamp_ns']))/1e3)
lat.sort()
q=lambda p: lat[min(len(lat)-1,int(p*len(lat)))]
print(f"listener on CPU {w}: {len(lat)} PmcSample, latency p50 {q(.5):.0f} us, p90 {q(.9):.0f} us, p99 {q(.99):.0f} us, max {lat[-1]:.0f} us")
PY
  grep -o "totals: [^;]*" log$where
done

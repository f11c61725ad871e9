#!/usr/bin/env bash
# The paper's experiments 1-3 on rclcpp (rosguard_rclcpp's middleware_bench, one process: an nRT
# node streaming bandwidth_read over 64 MB under NrtGuard on the last usable CPU, the Controller
# on the first, an RtJob), over sampling periods 100 .. 5000 us, self and external sampling,
# REPS repetitions of SECONDS each; prints the runs' JSON lines to $OUT/runs.jsonl and a
# Markdown table of docs/middleware-costs.md's "rclcpp (rosguard_rclcpp)" on stdout.
# Needs `make ros2` first, 2 CPUs, root for SCHED_FIFO; takes about 5 minutes with the defaults.
# Usage: tools/ros2/middleware_bench.sh [BUILD_DIR]   (env: REPS=3 SECONDS_PER_RUN=3
#        PERIODS="100 200 500 1000 2000 5000" OUT=results/ros2-middleware ROS_DOMAIN_ID=154)
set -euo pipefail
cd "$(dirname "$0")/../.."
build=${1:-build}
reps=${REPS:-3}
secs=${SECONDS_PER_RUN:-3}
periods=${PERIODS:-"100 200 500 1000 2000 5000"}
out=${OUT:-results/ros2-middleware}
[[ -f $build/ros2/env.sh ]] || { echo "middleware_bench.sh: no $build/ros2/env.sh: run make ros2 first" >&2; exit 2; }
set +u
# shellcheck source=/dev/null
source "$build/ros2/env.sh"
set -u
export ROS_DOMAIN_ID=${ROS_DOMAIN_ID:-154}
export CYCLONEDDS_URI="file://$PWD/tests/hw/cyclonedds-loopback.xml,file://$PWD/ros2/rosguard_rclcpp/config/cyclonedds-threads.xml"
bench=$build/ros2/install/lib/rosguard_rclcpp/middleware_bench
[[ -x $bench ]] || { echo "middleware_bench.sh: no $bench: run make ros2 first" >&2; exit 2; }
mkdir -p "$out"
runs=$out/runs.jsonl
: >"$runs"
# Each repetition goes over every point once, the baseline (none) next to the monitor run it is
# compared with, so a slower stretch of a shared host weighs on both.
for rep in $(seq "$reps"); do
  for p in $periods; do
    for args in "none self" "monitor self" "regulate self" "regulate external"; do
      read -r mode sampling <<<"$args"
      line=$("$bench" --mode "$mode" --sampling "$sampling" --period-us "$p" --seconds "$secs" 2>>"$out/stderr.log") || {
        echo "middleware_bench.sh: $bench --mode $mode --sampling $sampling --period-us $p failed (see $out/stderr.log)" >&2
        exit 1
      }
      echo "{\"rep\": $rep, ${line#\{}" >>"$runs"
    done
  done
done
/usr/bin/python3 - "$runs" "$reps" "$secs" <<'PY'
import json, statistics, sys
from collections import defaultdict
runs = [json.loads(l) for l in open(sys.argv[1])]
by = defaultdict(list)
for r in runs:
    by[(r["mode"], r["sampling"], r["period_us"])].append(r)
periods = sorted({r["period_us"] for r in runs})
med = statistics.median
def delay(rs):
    rs = [r for r in rs if r["activation_delay_us"]["n"]]
    if not rs:
        return "-"
    d = [r["activation_delay_us"] for r in rs]
    return f'{med(x["p50"] for x in d):.1f} [{min(x["min"] for x in d):.1f}, {max(x["max"] for x in d):.1f}] (n {sum(x["n"] for x in d)})'
print(f"rclcpp middleware_bench, {sys.argv[2]} repetitions x {sys.argv[3]} s per point; medians of the "
      "repetitions' p50, [min, max] over all of them\n")
print("| sampling period (us) | PMC callback p50 (us) | PMC thread CPU per period (us, share) | nRT slowdown monitor / none | sample transit p50 (us) | activation delay self p50 [min, max] (us) | activation delay external p50 [min, max] (us) |")
print("|---|---|---|---|---|---|---|")
for p in periods:
    mon = by[("monitor", "self", p)]
    none = {r["rep"]: r["rate_mbps"] for r in by[("none", "self", p)]}
    cb = med(r["pmc_callback_us"]["p50"] for r in mon) if mon else float("nan")
    cpu = [r["pmc_thread_cpu_us_per_period"] for r in mon if r["pmc_thread_cpu_us_per_period"] is not None]
    cpu_s = f"{med(cpu):.1f} ({100 * med(cpu) / p:.1f} %)" if cpu else "-"
    ratios = [none[r["rep"]] / r["rate_mbps"] for r in mon if r["rep"] in none and r["rate_mbps"] > 0]
    slow = f"x{med(ratios):.3f} [{min(ratios):.3f}, {max(ratios):.3f}]" if ratios else "-"
    transit = med(r["sample_transit_us"]["p50"] for r in mon) if mon else float("nan")
    print(f"| {p} | {cb:.1f} | {cpu_s} | {slow} | {transit:.1f} | {delay(by[('regulate', 'self', p)])} | {delay(by[('regulate', 'external', p)])} |")
base = [r["rate_mbps"] for r in runs if r["mode"] == "none"]
if base:
    print(f"\nnRT node alone (none): median {med(base):.0f} MB/s, range {min(base):.0f}-{max(base):.0f} over {len(base)} runs")
PY

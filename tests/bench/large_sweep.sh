#!/usr/bin/env bash
# A large sweep's cost to the runner: wall time, the runner's peak memory (VmHWM of the runner
# process alone, sampled every 0.2 s; the task hosts and workers are separate processes) and
# its growth per point, and how long `rosguard status` takes on the finished folder.
# Not a test: nothing is asserted (the machine may be shared), but the run must succeed and write
# every row.
# Usage: tests/bench/large_sweep.sh [BUILD_DIR] [N] [SCENARIO]
#   defaults: build, the CPUs online, scenarios/bench/sweep-100k.json (100,000 points; its
#   samples.csv is some 1.6 GB: the results go to a temporary folder, removed at the end)
set -euo pipefail
build=${1:-build}
jobs=${2:-$(nproc)}
scenario=${3:-scenarios/bench/sweep-100k.json}
exe="$build/rosguard"
[[ -x $exe ]] || { echo "error: $exe not found (build first: make build)" >&2; exit 2; }
[[ -f $scenario ]] || { echo "error: $scenario not found" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
points=$("$exe" check "$scenario" 2>/dev/null | awk '$2 == "points" && NF == 2 {print $1}')
echo "$scenario: $points points at --jobs $jobs ($(nproc) CPUs)"
start=$(date +%s.%N)
"$exe" run "$scenario" --out "$tmp/out" --quiet --jobs "$jobs" 2>"$tmp/err" &
pid=$!
hwm=0
while kill -0 "$pid" 2>/dev/null; do
  v=$(awk '/^VmHWM/ {print $2}' "/proc/$pid/status" 2>/dev/null || true)
  [[ -n $v ]] && hwm=$v
  sleep 0.2
done
wait "$pid" || { cat "$tmp/err" >&2; echo "error: the run failed" >&2; exit 1; }
end=$(date +%s.%N)
rows=$(($(wc -l <"$tmp/out/points.csv") - 1))
awk -v s="$start" -v e="$end" -v r="$rows" -v h="$hwm" -v p="$points" 'BEGIN {
  printf "run: %d rows in %.1f s (%.0f runs/s); runner peak memory %.0f MB, %.1f KB per point\n",
    r, e - s, r / (e - s), h / 1024, h / p }'
du -sh "$tmp/out"/points.csv "$tmp/out"/samples.csv | awk '{printf "  %s %s\n", $2, $1}' |
  sed "s|$tmp/out/||"
TIMEFORMAT='status: %R s'
time "$exe" status "$tmp/out" >/dev/null

#!/usr/bin/env bash
# Wall time of whole runs of the CLI, median over repeats (the machine may be shared: one run
# says little). Not a test: nothing is asserted.
# Usage: tests/bench/time_sweep.sh [BUILD_DIR] [REPEATS] [JOBS]    (from the source root)
# Times scenarios/bench/sweep-100.json (100 points + isolation baselines; target < 20 s on 2
# cores) and scenarios/quickstart.json (target < 15 s on 2 cores).
set -euo pipefail
build=${1:-build}
repeats=${2:-5}
jobs=${3:-2}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for scenario in scenarios/bench/sweep-100.json scenarios/quickstart.json; do
  times=()
  for ((i = 0; i < repeats; i++)); do
    start=$(date +%s.%N)
    "$build/rosguard" run "$scenario" --out "$tmp/out" --overwrite --quiet --jobs "$jobs"
    end=$(date +%s.%N)
    times+=("$(echo "$end - $start" | bc -l)")
  done
  sorted=$(printf '%s\n' "${times[@]}" | sort -g)
  median=$(echo "$sorted" | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}')
  rows=$(($(wc -l <"$tmp/out/points.csv") - 1))
  printf '%-36s %3d rows  --jobs %s  median %.3f s  (min %.3f, max %.3f, %d runs)\n' \
    "$scenario" "$rows" "$jobs" "$median" "$(echo "$sorted" | head -1)" "$(echo "$sorted" | tail -1)" "$repeats"
done

#!/usr/bin/env bash
# Parallel efficiency of `rosguard run` on the sim backend: wall time of a whole sweep at
# --jobs 1 and --jobs N, median over repeats, points per second and efficiency
# T(1) / (N x T(N)). Not a test: nothing is asserted (the machine may be shared).
# Usage: tests/bench/parallel_efficiency.sh [BUILD_DIR] [REPEATS] [N] [SCENARIO] [SHARD]
#   defaults: build 5 2 scenarios/bench/sweep-10k.json (SHARD, e.g. 0/10, times a tenth)
set -euo pipefail
build=${1:-build}
repeats=${2:-5}
jobs=${3:-2}
scenario=${4:-scenarios/bench/sweep-10k.json}
shard=${5:-0/1}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
median_of() { sort -g | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'; }
declare -A median
for j in 1 "$jobs"; do
  times=()
  for ((i = 0; i < repeats; i++)); do
    start=$(date +%s.%N)
    "$build/rosguard" run "$scenario" --out "$tmp/out" --overwrite --quiet --jobs "$j" --shard "$shard"
    end=$(date +%s.%N)
    times+=("$(echo "$end - $start" | bc -l)")
  done
  median[$j]=$(printf '%s\n' "${times[@]}" | median_of)
  rows=$(($(wc -l <"$tmp/out/points.csv") - 1))
  printf '%s --jobs %-3s %6d runs  median %8.2f s  %8.1f runs/s  (%s)\n' "$scenario" "$j" "$rows" \
    "${median[$j]}" "$(echo "$rows / ${median[$j]}" | bc -l)" "$(printf '%s ' "${times[@]}")"
done
printf 'parallel efficiency at --jobs %s: %.1f %%\n' "$jobs" \
  "$(echo "100 * ${median[1]} / ($jobs * ${median[$jobs]})" | bc -l)"

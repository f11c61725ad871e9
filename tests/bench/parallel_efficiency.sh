#!/usr/bin/env bash
# Parallel efficiency of `rosguard run` on the sim backend: wall time of a whole sweep at
# --jobs 1 and --jobs N, median over repeats, points per second and efficiency
# T(1) / (N x T(N)), and how many CPUs the run at --jobs N kept busy on average. Not a test:
# nothing is asserted about the times (the machine may be shared), but every run must succeed,
# write every row, and give the same points.csv and samples.csv at --jobs 1 and --jobs N.
# Usage: tests/bench/parallel_efficiency.sh [BUILD_DIR] [REPEATS] [N] [SCENARIO] [SHARD] [M]
#   defaults: build 5 2 scenarios/bench/sweep-10k.json 0/1 16 (SHARD 0/10 times a tenth; the
#   whole scenario is still loaded and checked, so a shard's efficiency is lower than the sweep's)
# The runs at --jobs 1 and --jobs N alternate, so that a change in the machine's load hits both.
# Each run's line has its wall time, the CPU time of all its processes (runner, task hosts,
# workers: bash's `time`, which counts every waited-for descendant) and the CPU time the rest of
# the machine used meanwhile (the busy time in /proc/stat less the run's own); when that exceeds
# 2 % of the run's CPU time, the machine was not quiet, which is said at the end. (The load
# average would count the benchmark's own runs.) Needs bash, awk and coreutils only (no bc, no
# /usr/bin/time), so that it runs on a machine without the development packages.
# The time outside the task loop (loading and checking the points, planning, the manifest, the
# process's start and end: the wall time less the manifest's elapsed_s, which is the task loop's)
# is what more workers cannot shorten, except the part spread over --jobs threads. From its
# medians at --jobs 1 and N, as a + b / n (a on one thread, b spread), the script estimates the
# efficiency at --jobs M on M CPUs like these: T(M) = a + b / M + W / M, with W the larger of the
# task loop's wall time at --jobs 1 and the CPU time of all processes at --jobs N less its time
# outside the loop (so that the runner and task hosts' own CPU time counts). An estimate, not a
# measurement: it assumes M equally fast CPUs and that nothing else in the task loop becomes a
# limit at M workers.
set -euo pipefail
build=${1:-build}
repeats=${2:-5}
jobs=${3:-2}
scenario=${4:-scenarios/bench/sweep-10k.json}
shard=${5:-0/1}
project=${6:-16}
exe="$build/rosguard"
[[ -x $exe ]] || { echo "error: $exe not found (build first: make build)" >&2; exit 2; }
[[ -f $scenario ]] || { echo "error: $scenario not found" >&2; exit 2; }
[[ $repeats -ge 1 && $jobs -ge 2 ]] || { echo "error: REPEATS >= 1 and N >= 2" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
calc() { awk "BEGIN {print $*}"; }
median_of() { sort -g | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'; }
busy_s() { # CPU seconds all CPUs spent busy since boot (user nice system irq softirq steal)
  awk -v hz="$(getconf CLK_TCK)" '/^cpu / {print ($2 + $3 + $4 + $7 + $8 + $9) / hz}' /proc/stat
}
declare -A walls cpus outs
max_other=0
echo "$scenario --shard $shard: $repeats runs each at --jobs 1 and --jobs $jobs, alternating" \
  "($(nproc) CPUs)"
TIMEFORMAT='%R %U %S'
for ((i = 0; i < repeats; i++)); do
  for j in 1 "$jobs"; do
    busy0=$(busy_s)
    { time "$exe" run "$scenario" --out "$tmp/out$j" --overwrite --quiet --jobs "$j" \
      --shard "$shard" 2>"$tmp/err"; } 2>"$tmp/time" ||
      { cat "$tmp/err" >&2; echo "error: the run at --jobs $j failed" >&2; exit 1; }
    read -r wall user sys <"$tmp/time"
    cpu=$(calc "$user + $sys")
    other=$(calc "$(busy_s) - $busy0 - $cpu")
    max_other=$(calc "($other / $cpu > $max_other) ? $other / $cpu : $max_other")
    # The task loop's wall time: the manifest's top-level elapsed_s (indented by 2).
    loop=$(awk -F'[:,]' '/^  "elapsed_s":/ {print $2 + 0}' "$tmp/out$j/manifest.json")
    walls[$j]+="$wall "
    cpus[$j]+="$cpu "
    outs[$j]+="$(calc "$wall - $loop") "
    printf '  run %d --jobs %-3s wall %8.2f s  cpu %8.2f s  outside the task loop %6.3f s  (rest of the machine %.2f s)\n' \
      "$i" "$j" "$wall" "$cpu" "$(calc "$wall - $loop")" "$other"
  done
  rows1=$(($(wc -l <"$tmp/out1/points.csv") - 1))
  rowsn=$(($(wc -l <"$tmp/out$jobs/points.csv") - 1))
  [[ $rows1 -gt 0 && $rows1 -eq $rowsn ]] || { echo "error: $rows1 rows at --jobs 1, $rowsn at --jobs $jobs" >&2; exit 1; }
  for f in points.csv samples.csv; do
    cmp -s "$tmp/out1/$f" "$tmp/out$jobs/$f" ||
      { echo "error: $f differs between --jobs 1 and --jobs $jobs" >&2; exit 1; }
  done
done
declare -A median cpum outm
for j in 1 "$jobs"; do
  median[$j]=$(tr ' ' '\n' <<<"${walls[$j]}" | grep . | median_of)
  cpum[$j]=$(tr ' ' '\n' <<<"${cpus[$j]}" | grep . | median_of)
  outm[$j]=$(tr ' ' '\n' <<<"${outs[$j]}" | grep . | median_of)
  printf '%s --jobs %-3s %6d runs  median %8.2f s  %8.1f runs/s  cpu %8.2f s  (%s)\n' \
    "$scenario" "$j" "$rows1" "${median[$j]}" "$(calc "$rows1 / ${median[$j]}")" "${cpum[$j]}" \
    "${walls[$j]% }"
done
printf 'parallel efficiency at --jobs %s: %.1f %%\n' "$jobs" \
  "$(calc "100 * ${median[1]} / ($jobs * ${median[$jobs]})")"
# The same work can take more CPU time at --jobs 1 than at --jobs N (seen on the 2-vCPU
# development VM: 1.12-1.36 times; why is not established), which flatters the figure above; how
# busy the run kept its N CPUs does not depend on the --jobs 1 run.
printf 'CPU time at --jobs 1 / --jobs %s: %.3f; --jobs %s kept %.1f CPUs busy on average (%.1f %% of %s)\n' \
  "$jobs" "$(calc "${cpum[1]} / ${cpum[$jobs]}")" "$jobs" \
  "$(calc "${cpum[$jobs]} / ${median[$jobs]}")" \
  "$(calc "100 * ${cpum[$jobs]} / ($jobs * ${median[$jobs]})")" "$jobs"
# Outside the task loop as a + b / n from --jobs 1 and N (b: the part spread over threads).
b=$(calc "(${outm[1]} > ${outm[$jobs]}) ? (${outm[1]} - ${outm[$jobs]}) * $jobs / ($jobs - 1) : 0")
b=$(calc "($b < ${outm[1]}) ? $b : ${outm[1]}")
a=$(calc "${outm[1]} - $b")
work=$(calc "${median[1]} - ${outm[1]}")
cpu_loop=$(calc "${cpum[$jobs]} - ${outm[$jobs]}")
work=$(calc "($cpu_loop > $work) ? $cpu_loop : $work")
t_m=$(calc "$a + ($b + $work) / $project")
printf 'outside the task loop: median %.3f s at --jobs 1, %.3f s at --jobs %s: %.3f s on one thread + %.3f s spread over --jobs threads\n' \
  "${outm[1]}" "${outm[$jobs]}" "$jobs" "$a" "$b"
printf 'estimated (not measured) at --jobs %s on %s CPUs like these: %.2f s, efficiency %.1f %%\n' \
  "$project" "$project" "$t_m" "$(calc "100 * ${median[1]} / ($project * $t_m)")"
if [[ $(calc "($max_other > 0.02) ? 1 : 0") == 1 ]]; then
  printf 'note: other processes used up to %.1f %% of a run'"'"'s CPU time: the machine was not quiet,' \
    "$(calc "100 * $max_other")"
  echo " so these wall times (and the efficiency) are not the tool's alone"
fi

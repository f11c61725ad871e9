#!/usr/bin/env bash
# Issue 23 item 1: an intruder on the DDS domain (another process, no credentials) cannot stop or
# unbalance `rosguard guard`. It sends an unmatched 'false', a double 'true', a 'false' during a
# real RT job (rosguard-rt-node), 10^5 alternating messages during that job, and fake commands
# and PMC samples on the guard's topics. The guard keeps running and regulating: the pinned
# stress-ng stays within its budget while the real job runs, every ignored message is logged with
# its publisher's GUID (repeats summed up, so the log stays short), and SIGTERM ends it cleanly.
# Usage: guard_intruder.sh ROSGUARD RT_NODE INTRUDER SOURCE_DIR
set -euo pipefail
rosguard=$1
rt_node=$2
intruder=$3
src=$4
# shellcheck source=guard_common.sh
source "$src/tests/hw/guard_common.sh"
# (|| true: an empty log, or head closing the pipe, must not end the script before it says why)
fail() { echo "--- guard log"; grep -v -- "-> THR\|-> ON" "$tmp/log" | head -60 || true; echo "FAIL: $*"; exit 1; }
guard_start intruded

# CPU time (ns) of stress-ng's worker; its share of one CPU over 1 s.
# The worker of the stress-ng guard_start started (not any other stress-ng on the machine).
worker=$(pgrep -P "$stress_pid" | head -1)
[[ -n $worker ]] || fail "no worker of stress-ng $stress_pid"
cpu_ns() { awk '{print $1}' "/proc/$worker/schedstat"; }
share() {
  local c0 t0 c1 t1
  c0=$(cpu_ns); t0=$(date +%s%N); sleep 1; c1=$(cpu_ns); t1=$(date +%s%N)
  echo "$c0 $c1 $t0 $t1" | awk '{printf "%.3f", ($2 - $1) / ($4 - $3)}'
}
alive() { kill -0 "$guard_pid" 2>/dev/null || fail "the guard died: $1"; }

free=$(share)
# Before any RT job: an unmatched 'false', a double 'true' and its 'false', in one process.
"$intruder" --ns "$ns" active planner 0 active planner 1 active planner 1 active planner 0 \
  >"$tmp/intruder1.out"
sleep 0.3
alive "after an unmatched false and a double true"
# The real RT job (4 s on core 0), and meanwhile the intruder: a 'false', a flood, fake commands
# and samples on the guard's own topics; it stays on the domain while stress-ng is measured.
"$rt_node" --name planner --ns "$ns" --jobs 1 --job-ms 4000 --core 0 --working-set-kb 4096 \
  --wait-ms 20000 >"$tmp/rt.out" &
rt_pid=$!
extra_pids=$rt_pid
for _ in $(seq 100); do [[ $(grep -c "planner: active (publisher" "$tmp/log") -ge 2 ]] && break; sleep 0.05; done
"$intruder" --ns "$ns" active planner 0 flood planner 100000 sleep 2000 >"$tmp/intruder2.out" &
intruder_pid=$!
# Nobody here reads the guard's output topics; the writes must not disturb it all the same.
"$intruder" --ns "$ns" --wait-ms 0 command be 2 1000 command be 7 10 pmc be 1000 \
  >"$tmp/intruder3.out"
sleep 1
during=$(share)
alive "during the flood"
wait "$intruder_pid"
wait "$rt_pid" || true
sleep 0.5
after=$(share)
alive "after the intruder left"
# A 'true' from a publisher that then leaves the domain: what it held ends with it.
"$intruder" --ns "$ns" active planner 1 sleep 300 >"$tmp/intruder4.out"
for _ in $(seq 100); do grep -q "publisher is gone" "$tmp/log" && break; sleep 0.05; done
left=$(share)
kill -TERM "$guard_pid"
rc=0
wait "$guard_pid" || rc=$?
guard_pid=""
cat "$tmp"/intruder*.out
echo "stress-ng share of CPU 1: unregulated $free, during the real job under attack $during," \
  "after $after, after a 'true' whose publisher left $left"
grep -E "totals:|ignored" "$tmp/log" | head -20
lines=$(wc -l <"$tmp/log")
[[ $rc -eq 0 ]] || fail "guard exited $rc"
grep -q "ignored 'false' for planner (publisher writer 0x[0-9a-f]\{32\})" "$tmp/log" ||
  fail "the unmatched false is not logged with its publisher"
grep -q "ignored a repeated 'true' for planner (publisher writer 0x[0-9a-f]\{32\})" "$tmp/log" ||
  fail "the double true is not logged with its publisher"
grep -q "totals: .* activity: [1-9][0-9]* message(s) ignored, 0 activation(s) ended by activity.max_active_ms, 1 by their publisher leaving" "$tmp/log" ||
  fail "the totals do not count the ignored messages and the publisher that left"
grep -q "warning: planner: active for .* from publisher writer 0x[0-9a-f]\{32\}, its publisher is gone" "$tmp/log" ||
  fail "the activation of the publisher that left did not end with it"
grep -q "stopped: 1 core(s) back to nominal, every guard thread joined, 0 thread(s) left under SCHED_FIFO" "$tmp/log" ||
  fail "no clean stop"
# 10^5 messages, a few dozen lines: repeats are summed up, not logged one by one.
((lines < 200)) || fail "the log has $lines lines"
# Regulation held while the real job ran (10 % of each 10 ms window, plus the CPU-time clock's
# steps: the bound of the in-process guard test, with room for the shell's coarser measurement).
if awk -v f="$free" 'BEGIN { exit !(f < 0.6) }'; then
  echo "SKIPPED (CPU shares): other work held CPU 1 (stress-ng got $free of it unregulated)"
else
  awk -v d="$during" -v f="$free" 'BEGIN { exit !(d < 0.5 && d < 0.6 * f) }' ||
    fail "stress-ng got $during of CPU 1 during the real RT job (unregulated: $free)"
  awk -v a="$after" -v d="$during" 'BEGIN { exit !(a > 1.5 * d) }' ||
    fail "stress-ng got $after after the job: still held ($during during it)"
  awk -v l="$left" -v d="$during" 'BEGIN { exit !(l > 1.5 * d) }' ||
    fail "stress-ng got $left after the publisher of a 'true' left: still held"
fi
echo "OK: the guard ignored the intruder ($lines log lines) and regulated the real job"

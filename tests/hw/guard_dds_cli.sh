#!/usr/bin/env bash
# Issue 13 item 3: `rosguard guard` regulates a stress-ng process pinned on an nRT core while an
# RT program in another process (rosguard-rt-node) signals its jobs over DDS
# (/rosguard/planner/active, std_msgs/msg/Bool); SIGTERM then leaves no throttled core and no
# SCHED_FIFO thread, exit 0.
# Usage: guard_dds_cli.sh ROSGUARD RT_NODE SOURCE_DIR
set -euo pipefail
rosguard=$1
rt_node=$2
src=$3
# shellcheck source=guard_common.sh
source "$src/tests/hw/guard_common.sh"
guard_start clitest
# The RT program: 3 jobs of 300 ms on core 0, signalled over DDS.
"$rt_node" --name planner --ns "$ns" --jobs 3 --job-ms 300 --gap-ms 200 --core 0 \
  --working-set-kb 4096 --wait-ms 20000 >"$tmp/rt.out"
sleep 0.3
# Once more, and stop the guard while regulation is active.
"$rt_node" --name planner --ns "$ns" --jobs 1 --job-ms 3000 --core 0 --working-set-kb 4096 \
  --wait-ms 20000 >/dev/null &
rt_pid=$!
extra_pids=$rt_pid
# (Repeated log lines are left out: each RT program's writer logs its first activation.)
for _ in $(seq 100); do [[ $(grep -c "planner: active (publisher" "$tmp/log") -ge 2 ]] && break; sleep 0.05; done
sleep 0.2
kill -TERM "$guard_pid"
rc=0
wait "$guard_pid" || rc=$?
guard_pid=""
kill "$rt_pid" 2>/dev/null || true
wait "$rt_pid" 2>/dev/null || true
grep -v -- "-> THR\|-> ON" "$tmp/log" | head -40 || true
fail() { echo "FAIL: $*"; exit 1; }
[[ $rc -eq 0 ]] || fail "guard exited $rc"
grep -q "totals: 4 activation(s)" "$tmp/log" || fail "expected 4 activations"
[[ $(grep -c "planner: active (publisher writer 0x" "$tmp/log") -eq 2 ]] ||
  fail "expected the first activation of each RT program, with its writer's GUID"
thr=$(sed -n 's/.*totals: [0-9]* activation(s), \([0-9]*\) THR command(s).*/\1/p' "$tmp/log")
[[ $thr -ge 10 ]] || fail "expected the core throttled during the jobs ($thr THR)"
grep -q "SIGTERM received" "$tmp/log" || fail "no SIGTERM line"
grep -q "stopped: 1 core(s) back to nominal, every guard thread joined, 0 thread(s) left under SCHED_FIFO" "$tmp/log" || fail "no clean stop"
# Nothing left: no guard thread anywhere, and stress-ng runs under its own policy again.
if ps -eLo comm | grep -q "^be-thr\|^be-cfb"; then fail "a guard thread is still alive"; fi
for t in /proc/$(pgrep -P "$stress_pid" | head -1)/task/*; do
  pol=$(chrt -p "$(basename "$t")" | head -1)
  [[ $pol == *SCHED_OTHER* ]] || fail "stress-ng thread left as: $pol"
done
echo "OK: $thr THR commands over 4 activations; clean SIGTERM"

#!/usr/bin/env bash
# Issue 52: `rosguard guard` regulating a real nRT process (stress-ng pinned on CPU 1) is driven
# by an rclcpp node: its std_msgs/msg/Bool on /<ns>/rosguard/planner/active starts and stops
# regulation (the guard counts one activation per job sent), and an rclcpp subscriber decodes
# the guard's /<ns>/rosguard/be/command (rosguard_msgs/msg/Command: as many THR as the guard's
# totals count) and /be/pmc (rosguard_msgs/msg/PmcSample, count 3).
# Usage: guard.sh ROSGUARD BUILD_DIR SOURCE_DIR DOMAIN
set -euo pipefail
rosguard=$1 build=$2 src=$3 domain=$4
# shellcheck source=ros2_common.sh
source "$src/tests/ros2/ros2_common.sh"
# shellcheck source=../hw/guard_common.sh
source "$src/tests/hw/guard_common.sh"
fail() { echo "FAIL: $*"; exit 1; }

guard_start ros2guard "\"domain_id\": $domain"
"$peer" listen --ns "$ns" --command be --pmc be --seconds 120 >"$tmp/heard.jsonl" &
extra_pids=$!
peer_ready "$tmp/heard.jsonl"
"$peer" signal --ns "$ns" --name planner --jobs 5 --job-ms 300 --gap-ms 200 --wait-ms 20000 \
  >"$tmp/sent.jsonl" || { cat "$tmp/sent.jsonl"; fail "the rclcpp RT node did not run"; }
sleep 0.5
kill -TERM "$guard_pid"
rc=0
wait "$guard_pid" || rc=$?
guard_pid=""
sleep 0.5
kill -INT "$extra_pids"
wait "$extra_pids" || true
grep -v -- "-> THR\|-> ON\|-> REPLENISH" "$tmp/log" | head -30 || true
[[ $rc -eq 0 ]] || fail "guard exited $rc"

sent=$(count_json "$tmp/sent.jsonl" 'm.get("event") == "sent"')
jobs=$(count_json "$tmp/sent.jsonl" 'm.get("event") == "sent" and m["data"]')
thr_heard=$(count_json "$tmp/heard.jsonl" 'm.get("topic") == "command" and m["command"] == 2')
pmc_heard=$(count_json "$tmp/heard.jsonl" 'm.get("topic") == "pmc" and m["count"] == 3')
bad=$(count_json "$tmp/heard.jsonl" 'm.get("topic") == "command" and (m["command"] not in (0, 1, 2, 3, 255) or m["cause_ns"] < 0)')
totals=$(grep "totals:" "$tmp/log")
activations=$(sed -n 's/.*totals: \([0-9]*\) activation(s).*/\1/p' <<<"$totals")
thr=$(sed -n 's/.*totals: [0-9]* activation(s), \([0-9]*\) THR command(s).*/\1/p' <<<"$totals")
echo "rclcpp sent $sent messages ($jobs jobs); guard: $activations activation(s), $thr THR; rclcpp heard $thr_heard THR, $pmc_heard PmcSample"
[[ $sent -eq 10 ]] || fail "the rclcpp node sent $sent messages, expected 10"
[[ $activations -eq $jobs ]] || fail "the guard counted $activations activations for $jobs jobs"
[[ $thr -ge $jobs ]] || fail "only $thr THR commands over $jobs regulated jobs"
[[ $thr_heard -eq $thr ]] || fail "rclcpp heard $thr_heard THR commands, the guard sent $thr"
[[ $pmc_heard -gt 0 ]] || fail "rclcpp heard no PmcSample of 3 values"
[[ $bad -eq 0 ]] || fail "$bad commands with a code rosguard_msgs/msg/Command does not define, or a negative cause_ns"
grep -q "planner: active (publisher writer 0x" "$tmp/log" ||
  fail "the guard's log does not name the rclcpp writer"
echo "PASS"

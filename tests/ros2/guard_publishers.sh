#!/usr/bin/env bash
# Issue 52 (issue 23's per-publisher activity, with real rclcpp publishers): `rosguard guard`
# keeps an RT node's activity per publisher when the publishers are rclcpp nodes.
# - Two rclcpp nodes signal the same RT name, overlapping: the second one's 'true' joins, its
#   'false' leaves the node active for the first, whose 'false' ends it (one activation).
# - An rclcpp node SIGKILLed in the middle of a job (its 'true' sent, no 'false'): the guard
#   releases the node when the writer is gone (its participant's lease expires), logs it, and the
#   core stops being throttled; the guard keeps running and stops cleanly.
# Usage: guard_publishers.sh ROSGUARD BUILD_DIR SOURCE_DIR DOMAIN
set -euo pipefail
rosguard=$1 build=$2 src=$3 domain=$4
# shellcheck source=ros2_common.sh
source "$src/tests/ros2/ros2_common.sh"
# shellcheck source=../hw/guard_common.sh
source "$src/tests/hw/guard_common.sh"
fail() { echo "--- guard log"; grep -v -- "-> THR\|-> ON\|-> REPLENISH" "$tmp/log" | head -60 || true; echo "FAIL: $*"; exit 1; }
wait_log() {  # PATTERN SECONDS
  for _ in $(seq $((${2} * 20))); do grep -q "$1" "$tmp/log" && return 0; sleep 0.05; done
  return 1
}

guard_start ros2pubs "\"domain_id\": $domain"

# Two rclcpp nodes, one RT name: first holds it 2 s, second joins for 0.5 s inside that.
"$peer" signal --node first --ns "$ns" --name planner --jobs 1 --job-ms 2000 --wait-ms 20000 \
  >"$tmp/first.jsonl" &
first=$!
extra_pids=$first
wait_log "planner: active (publisher" 20 || fail "the first rclcpp node's 'true' was not heard"
"$peer" signal --node second --ns "$ns" --name planner --jobs 1 --job-ms 500 --wait-ms 20000 \
  >"$tmp/second.jsonl" || fail "the second rclcpp node did not run"
wait "$first" || fail "the first rclcpp node failed"
wait_log "planner: inactive (publisher" 5 || fail "the node was not released by the first node's 'false'"
grep -q "planner: active from a further publisher" "$tmp/log" || fail "the second node did not join"
grep -q "planner: 'false' (publisher .*); still active for 1 other publisher(s)" "$tmp/log" ||
  fail "the second node's 'false' did not leave the node active for the first"

# An rclcpp node killed in its job: its 'true' holds the node until its writer is gone.
"$peer" signal --node crasher --ns "$ns" --name planner --jobs 2 --job-ms 3000 --wait-ms 20000 \
  --die-in-job 1 >"$tmp/crasher.jsonl" || true
grep -q '"event": "killing itself"' "$tmp/crasher.jsonl" || fail "the crashing node did not run"
t_kill=$(date +%s%N)
# Cyclone's default participant lease is 10 s; the guard takes the writer's loss then.
wait_log "its publisher is gone" 30 || fail "the crashed node's activation was never released"
t_gone=$(date +%s%N)
# The core runs freely again: stress-ng's worker gets most of it over 1 s.
worker=$(pgrep -P "$stress_pid" | head -1)
c0=$(awk '{print $1}' "/proc/$worker/schedstat"); t0=$(date +%s%N); sleep 1
c1=$(awk '{print $1}' "/proc/$worker/schedstat"); t1=$(date +%s%N)
share=$(awk -v c0="$c0" -v c1="$c1" -v t0="$t0" -v t1="$t1" 'BEGIN { printf "%.2f", (c1 - c0) / (t1 - t0) }')
kill -TERM "$guard_pid"
rc=0
wait "$guard_pid" || rc=$?
guard_pid=""
grep -v -- "-> THR\|-> ON\|-> REPLENISH" "$tmp/log" | head -40 || true
[[ $rc -eq 0 ]] || fail "guard exited $rc"
echo "released $(((t_gone - t_kill) / 1000000)) ms after the rclcpp node's SIGKILL; stress-ng's share of its core afterwards: $share"
grep -q "totals: 2 activation(s), .* 0 activation(s) ended by activity.max_active_ms, 1 by their publisher leaving" "$tmp/log" ||
  fail "expected 2 activations, one of them ended by its publisher leaving"
awk -v s="$share" 'BEGIN { exit !(s > 0.5) }' || fail "the core is still throttled after the release (share $share)"
echo "PASS"

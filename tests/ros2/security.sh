#!/usr/bin/env bash
# Issue 52: DDS Security the ROS 2 way. `rosguard guard` runs with DDS Security (a test CA of
# docs/guard/security/make_certs.sh); an rclcpp node configured as ROS 2 configures security
# (ROS_SECURITY_ENABLE=true, ROS_SECURITY_STRATEGY=Enforce, ROS_SECURITY_KEYSTORE with the enclave
# /planner laid out by docs/guard/security/ros2_enclave.sh, `--ros-args --enclave /planner`) is
# heard and drives regulation; the same rclcpp node without credentials is never matched and
# activates nothing.
# Usage: security.sh ROSGUARD BUILD_DIR SOURCE_DIR DOMAIN
set -euo pipefail
rosguard=$1 build=$2 src=$3 domain=$4
command -v openssl >/dev/null || { echo "SKIPPED: openssl is not installed"; exit 0; }
# shellcheck source=ros2_common.sh
source "$src/tests/ros2/ros2_common.sh"
# shellcheck source=../hw/guard_common.sh
source "$src/tests/hw/guard_common.sh"
fail() { echo "--- guard log"; grep -v -- "-> THR\|-> ON\|-> REPLENISH" "$tmp/log" | head -60 || true; echo "FAIL: $*"; exit 1; }

"$src/docs/guard/security/make_certs.sh" "$tmp/ca" guard planner >/dev/null
"$src/docs/guard/security/ros2_enclave.sh" "$tmp/ca" planner "$tmp/keystore" >/dev/null
guard_start secured "\"domain_id\": $domain, \"security\": { \"identity_ca\": \"ca/ca.pem\",
  \"identity_certificate\": \"ca/guard.pem\", \"private_key\": \"ca/guard.key\",
  \"permissions_ca\": \"ca/ca.pem\", \"governance\": \"ca/governance.p7s\",
  \"permissions\": \"ca/permissions_guard.p7s\" }"
grep -q "with DDS Security" "$tmp/log" || fail "the guard does not say it runs with DDS Security"

# Without credentials: never matched, nothing activated.
rc=0
"$peer" signal --ns "$ns" --name planner --jobs 1 --job-ms 100 --wait-ms 4000 \
  >"$tmp/plain.jsonl" 2>"$tmp/plain.err" || rc=$?
cat "$tmp/plain.jsonl"
[[ $rc -eq 1 ]] && grep -q '"event": "unmatched"' "$tmp/plain.jsonl" ||
  fail "the rclcpp node without credentials was matched (exit $rc)"
grep -q "planner: active" "$tmp/log" && fail "an unauthenticated rclcpp node activated regulation"

# With the enclave: heard, 2 jobs, 2 activations.
ROS_SECURITY_ENABLE=true ROS_SECURITY_STRATEGY=Enforce ROS_SECURITY_KEYSTORE=$tmp/keystore \
  "$peer" signal --ns "$ns" --name planner --jobs 2 --job-ms 300 --gap-ms 200 --wait-ms 20000 \
  --ros-args --enclave /planner >"$tmp/secure.jsonl" 2>"$tmp/secure.err" ||
  { cat "$tmp/secure.jsonl" "$tmp/secure.err"; fail "the rclcpp node with its enclave was not matched"; }
cat "$tmp/secure.jsonl"
sleep 0.3
kill -TERM "$guard_pid"
rc=0
wait "$guard_pid" || rc=$?
guard_pid=""
grep -E "totals:|planner: active" "$tmp/log"
[[ $rc -eq 0 ]] || fail "guard exited $rc"
grep -q "totals: 2 activation(s)" "$tmp/log" || fail "expected the signed rclcpp node's 2 activations"
echo "PASS"

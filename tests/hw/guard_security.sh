#!/usr/bin/env bash
# Issue 23 item 2: `rosguard guard` with DDS Security. A test CA (docs/guard/security/
# make_certs.sh) signs the guard's and the RT program's certificates and permissions. A publisher
# without credentials and three whose certificates come from another CA say 'true' for the RT
# node: none is matched, the guard does not activate and stress-ng on the nRT core runs free. Each
# foreign certificate is refused and logged by the side that checks it: DDS Security's handshake
# is started by the participant whose GUID (derived from a hash of its certificate's subject) is
# smaller, and the other side checks the certificate it receives. With these subjects the guard
# checks two ("cyclone: Begin handshake reply failed ... subject: /CN=bravo" in its log) and the
# third ("rogue") refuses the guard's. The signed RT program (rosguard-rt-node with its identity in
# CYCLONEDDS_URI) is heard and regulated.
# Usage: guard_security.sh ROSGUARD RT_NODE INTRUDER SOURCE_DIR
set -euo pipefail
rosguard=$1
rt_node=$2
intruder=$3
src=$4
command -v openssl >/dev/null || { echo "SKIPPED: openssl is not installed"; exit 0; }
# shellcheck source=guard_common.sh
source "$src/tests/hw/guard_common.sh"
# (|| true: an empty log, or head closing the pipe, must not end the script before it says why)
fail() { echo "--- guard log"; grep -v -- "-> THR\|-> ON" "$tmp/log" | head -60 || true; echo "FAIL: $*"; exit 1; }
plugins=$(dirname "$(ldconfig -p | awk '/libddsc\.so/ {print $NF; exit}')")
[[ -e $plugins/libddsc0debian/libdds_security_auth.so ]] && plugins=$plugins/libddsc0debian
[[ -e $plugins/libdds_security_auth.so ]] || { echo "SKIPPED: Cyclone's DDS Security plugins are not installed"; exit 0; }
"$src/docs/guard/security/make_certs.sh" "$tmp/ca" guard planner >/dev/null
rogues="rogue bravo charlie"
# shellcheck disable=SC2086
"$src/docs/guard/security/make_certs.sh" "$tmp/other" $rogues >/dev/null
# shellcheck source=security_identity.sh
source "$src/tests/hw/security_identity.sh"
identity_xml "$tmp/ca" planner >"$tmp/planner.xml"
for r in $rogues; do identity_xml "$tmp/other" "$r" >"$tmp/$r.xml"; done
guard_start secured '"security": { "identity_ca": "ca/ca.pem", "identity_certificate": "ca/guard.pem",
  "private_key": "ca/guard.key", "permissions_ca": "ca/ca.pem", "governance": "ca/governance.p7s",
  "permissions": "ca/permissions_guard.p7s" }'
grep -q "with DDS Security" "$tmp/log" || fail "the guard does not say it runs with DDS Security"
! grep -q "no DDS Security" "$tmp/log" || fail "the guard warns about a missing DDS Security"

# The worker of the stress-ng guard_start started (not any other stress-ng on the machine).
worker=$(pgrep -P "$stress_pid" | head -1)
[[ -n $worker ]] || fail "no worker of stress-ng $stress_pid"
share() {
  local c0 t0 c1 t1
  c0=$(awk '{print $1}' "/proc/$worker/schedstat"); t0=$(date +%s%N); sleep 1
  c1=$(awk '{print $1}' "/proc/$worker/schedstat"); t1=$(date +%s%N)
  echo "$c0 $c1 $t0 $t1" | awk '{printf "%.3f", ($2 - $1) / ($4 - $3)}'
}
# No credentials, and certificates of another CA: all say 'true' and stay a while.
"$intruder" --ns "$ns" --wait-ms 3000 active planner 1 >"$tmp/plain.out" &
extra_pids=$!
for r in $rogues; do
  CYCLONEDDS_URI="file://$tmp/$r.xml" "$intruder" --ns "$ns" --wait-ms 3000 active planner 1 \
    >"$tmp/$r.out" 2>"$tmp/$r.err" &
  extra_pids="$extra_pids $!"
done
sleep 1.5
attacked=$(share)
# shellcheck disable=SC2086
wait $extra_pids || true
grep -q "regulation active" "$tmp/log" && fail "an unauthenticated publisher activated regulation"
# The signed RT program: one 3 s job.
CYCLONEDDS_URI="file://$tmp/planner.xml" "$rt_node" --name planner --ns "$ns" --jobs 1 \
  --job-ms 3000 --core 0 --working-set-kb 4096 --wait-ms 20000 >"$tmp/rt.out" 2>&1 &
rt=$!
extra_pids="$rt"
for _ in $(seq 200); do grep -q "planner: active (publisher" "$tmp/log" && break; sleep 0.05; done
sleep 0.3
signed=$(share)
wait "$rt" || true
kill -TERM "$guard_pid"
rc=0
wait "$guard_pid" || rc=$?
guard_pid=""
cat "$tmp/plain.out" "$tmp/rt.out"
echo "stress-ng share of CPU 1: while the intruders said 'true' $attacked, during the signed job $signed"
grep -E "totals:|planner: active" "$tmp/log"
[[ $rc -eq 0 ]] || fail "guard exited $rc"
grep -q "active planner 1 (matched 0)" "$tmp/plain.out" || fail "the publisher without credentials was matched"
checked_by_guard=0
for r in $rogues; do
  grep -q "active planner 1 (matched 0)" "$tmp/$r.out" || fail "the publisher $r of another CA was matched"
  if grep -q "cyclone: .*handshake.*failed.*subject: /CN=$r/" "$tmp/log"; then
    echo "$r (another CA): refused and logged by the guard"
    checked_by_guard=$((checked_by_guard + 1))
  elif grep -q "handshake.*failed.*Certificate not valid" "$tmp/$r.err"; then
    echo "$r (another CA): started no handshake; it refused the guard's certificate and logged it"
  else
    fail "the refusal of $r's certificate is logged by neither side"
  fi
done
[[ $checked_by_guard -ge 1 ]] || fail "the guard logged no refused certificate"
grep -q "totals: 1 activation(s)" "$tmp/log" || fail "expected exactly the signed program's activation"
awk -v a="$attacked" -v s="$signed" 'BEGIN { exit !(a > 0.6 && s < 0.5 * a) }' ||
  echo "note (CPU shares, not checked: the machine may be busy): attacked $attacked, signed $signed"
echo "OK: unauthenticated and foreign-CA publishers unheard, the signed RT program regulates"

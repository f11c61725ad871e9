#!/usr/bin/env bash
# Issue 23 item 2 for hw runs: a scenario with hw.dds.security hears an RT node signalled by topic
# only from a program holding a certificate of its CA. The signed rosguard-rt-node's jobs are
# the point's; the same program with a certificate of another CA is never matched, and the point
# fails after hw.dds.signal_timeout_ms, naming the node.
# Usage: run_security.sh ROSGUARD RT_NODE SOURCE_DIR
set -euo pipefail
rosguard=$1
rt_node=$2
src=$3
command -v openssl >/dev/null || { echo "SKIPPED: openssl is not installed"; exit 0; }
plugins=$(dirname "$(ldconfig -p | awk '/libddsc\.so/ {print $NF; exit}')")
[[ -e $plugins/libddsc0debian/libdds_security_auth.so ]] && plugins=$plugins/libddsc0debian
[[ -e $plugins/libdds_security_auth.so ]] || { echo "SKIPPED: Cyclone's DDS Security plugins are not installed"; exit 0; }
tmp=$(mktemp -d)
run_pid=""
cleanup() {
  [[ -n "$run_pid" ]] && kill "$run_pid" 2>/dev/null || true
  rm -rf "$tmp"
}
trap cleanup EXIT
ns="/rosguard_test_runsec_$$_${RANDOM}"
export CYCLONEDDS_URI="file://$src/tests/hw/cyclonedds-loopback.xml"
"$src/docs/guard/security/make_certs.sh" "$tmp/ca" run planner >/dev/null
"$src/docs/guard/security/make_certs.sh" "$tmp/other" planner >/dev/null
# shellcheck source=security_identity.sh
source "$src/tests/hw/security_identity.sh"
identity_xml "$tmp/ca" planner >"$tmp/planner.xml"
identity_xml "$tmp/other" planner >"$tmp/rogue.xml"
scenario() {  # $1: signal timeout in ms
  cat <<JSON
{
  "name": "hw-test-run-security",
  "platform": "vm-2core",
  "backend": "hw",
  "repetitions": 1,
  "nodes": {
    "controller": { "core": 1 },
    "rt": [ { "name": "planner", "core": 0, "signal": "topic", "iterations": 2,
              "workload": { "name": "rt", "hw": { "kernel": "bandwidth_read", "working_set_kb": 4096, "passes": 3 } } } ],
    "nrt": [ { "name": "nrt0", "core": 1,
               "workload": { "name": "nrt", "hw": { "kernel": "bandwidth_read", "working_set_kb": 4096, "passes": 3 } } } ]
  },
  "regulation": { "policy": "interval", "sampling": "self", "sampling_period_us": 1000,
                  "regulation_period_us": 5000, "threshold_pct": 10 },
  "hw": { "pmc_source": "auto", "baseline_repetitions": 1, "transport": "dds",
          "dds": { "namespace": "$ns", "signal_timeout_ms": $1,
                   "security": { "identity_ca": "ca/ca.pem", "identity_certificate": "ca/run.pem",
                                 "private_key": "ca/run.key", "permissions_ca": "ca/ca.pem",
                                 "governance": "ca/governance.p7s", "permissions": "ca/permissions_run.p7s" } } }
}
JSON
}
scenario 60000 >"$tmp/signed.json"
"$rosguard" run "$tmp/signed.json" --out "$tmp/signed" --quiet >"$tmp/signed.log" 2>&1 &
run_pid=$!
CYCLONEDDS_URI="file://$tmp/planner.xml" "$rt_node" --name planner --ns "$ns" --core 0 --jobs 2 \
  --job-ms 200 --gap-ms 100 --working-set-kb 4096 --wait-ms 60000 --start-delay-ms 100 \
  >"$tmp/rt.log" 2>&1
rc=0
wait "$run_pid" || rc=$?
run_pid=""
cat "$tmp/rt.log"
[[ $rc -eq 0 ]] || { cat "$tmp/signed.log"; echo "FAIL: the run with the signed RT program exited $rc"; exit 1; }
jobs=$(/usr/bin/python3 -c "import csv,sys; print(next(csv.DictReader(open(sys.argv[1])))['rt_jobs'])" "$tmp/signed/points.csv")
[[ $jobs == 2 ]] || { echo "FAIL: rt_jobs $jobs, expected the signed program's 2"; exit 1; }
echo "signed RT program: 2 jobs in the point"

scenario 4000 >"$tmp/rogue.json"
"$rosguard" run "$tmp/rogue.json" --out "$tmp/rogue" --quiet >"$tmp/rogue.log" 2>&1 &
run_pid=$!
CYCLONEDDS_URI="file://$tmp/rogue.xml" "$rt_node" --name planner --ns "$ns" --core 0 --jobs 2 \
  --job-ms 200 --gap-ms 100 --working-set-kb 4096 --wait-ms 8000 >"$tmp/rogue-rt.log" 2>&1 || true
rc=0
wait "$run_pid" || rc=$?
run_pid=""
cat "$tmp/rogue-rt.log"
[[ $rc -ne 0 ]] || { echo "FAIL: the run took the jobs of a program with another CA's certificate"; exit 1; }
grep -q "planner (0 of 2 jobs)" "$tmp/rogue.log" || { cat "$tmp/rogue.log"; echo "FAIL: no signal timeout naming the node"; exit 1; }
echo "OK: the run hears the signed RT program only"

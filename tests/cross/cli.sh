#!/usr/bin/env bash
# The aarch64 rosguard under qemu-user (tests/cross/CMakeLists.txt): one case.
# Usage: cli.sh EMULATOR ROSGUARD CASE   (from the source root, ROSGUARD_HOME set)
#   help     --help and a command's --help print their usage
#   version  --version names the target's build: the hw backend, not the sim backend
#   probe    platform probe writes a platform: the PMU events it tried are the PMUv3 raw codes
#            (qemu-user emulates no PMU, so none opens) and the reference bandwidth is measured
#            by the cross-built bandwidth_read kernel (no host model: a fresh XDG_DATA_HOME)
#   check    a hw scenario on the probed host passes check; an invalid one exits 2, naming its
#            file and JSON path
set -uo pipefail
emulator=$1
rosguard=$2
case=$3
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# No installed host model (rosguard calibrate --install): the probe measures, the same everywhere.
export XDG_DATA_HOME=$tmp/data
unset ROSGUARD_HOST_MODEL

fail() {
  echo "FAIL: $*"
  exit 1
}
# Runs rosguard under the emulator: stdout to $tmp/out, stderr to $tmp/err, the status in $rc.
rg() {
  "$emulator" "$rosguard" "$@" >"$tmp/out" 2>"$tmp/err"
  rc=$?
  cat "$tmp/out" "$tmp/err"
}

case $case in
help)
  rg --help
  ((rc == 0)) || fail "rosguard --help exited $rc"
  grep -q '^Subcommands:' "$tmp/out" || fail "no Subcommands: in --help"
  rg platform probe --help
  ((rc == 0)) || fail "rosguard platform probe --help exited $rc"
  grep -q '^Usage: rosguard platform probe' "$tmp/out" || fail "no usage line"
  ;;
version)
  rg --version
  ((rc == 0)) || fail "rosguard --version exited $rc"
  grep -qx 'backends: hw' "$tmp/out" || fail "expected 'backends: hw' (a build without sim)"
  ;;
probe)
  rg platform probe --out "$tmp/host.json"
  ((rc == 0)) || fail "rosguard platform probe exited $rc"
  /usr/bin/python3 - "$tmp/host.json" <<'PY' || exit 1
import json, sys
doc = json.load(open(sys.argv[1]))
problems = []
# The first event tried is cpu_cycles: PERF_TYPE_RAW (4), PMUv3 event 0x11.
if "'cpu_cycles' (type 4 config 0x11)" not in doc["pmu"]["source"]:
    problems.append(f"pmu.source does not name cpu_cycles as type 4 config 0x11: {doc['pmu']}")
if not doc["reference"]["mbps"] > 0:
    problems.append(f"no measured reference bandwidth: {doc['reference']}")
for p in problems:
    print("FAIL:", p)
sys.exit(1 if problems else 0)
PY
  ;;
check)
  rg check scenarios/examples/host.json
  ((rc == 0)) || fail "rosguard check scenarios/examples/host.json exited $rc"
  grep -q '2 points' "$tmp/out" || fail "expected 2 points"
  # A case of the invalid corpus: exit 2, the message names the file and the JSON path.
  invalid=tests/invalid/hw-pmc-source-unknown.json
  rg check "$invalid"
  ((rc == 2)) || fail "rosguard check $invalid exited $rc, expected 2"
  expected=$(sed "s|{file}|$invalid|g" "${invalid%.json}.expected")
  grep -qxF "error: $expected" "$tmp/err" || fail "expected: error: $expected"
  ;;
*)
  fail "unknown case $case"
  ;;
esac
echo "ok: $case"

#!/usr/bin/env bash
# One case of the invalid-scenario corpus.
# Usage: run_case.sh ROSGUARD tests/invalid/CASE.json   (from the source root)
# CASE.expected holds the message after "error: "; {file} stands for the case's path.
set -u
rosguard=$1
case=$2
expected=$(sed "s|{file}|$case|g" "${case%.json}.expected")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
status=0

out=$("$rosguard" check "$case" 2>&1)
rc=$?
# A case for a backend this build leaves out (-DROSGUARD_WITH_SIM=OFF) loads, but the backend's
# own checks cannot run: skipped, not passed.
if [[ $rc -eq 0 ]] && grep -q "(not built into this rosguard)" <<<"$out"; then
  echo "SKIPPED: the case's backend is not built: $out"
  exit 0
fi
if [[ $rc -ne 2 ]]; then
  echo "FAIL: 'rosguard check' exited $rc, expected 2"
  status=1
fi
if ! grep -qxF "error: $expected" <<<"$out"; then
  echo "FAIL: 'rosguard check' did not print the expected message"
  status=1
fi
echo "check printed: $out"

out=$("$rosguard" run "$case" --out "$tmp/out" --quiet 2>&1)
rc=$?
if [[ $rc -ne 2 ]]; then
  echo "FAIL: 'rosguard run' exited $rc, expected 2: $out"
  status=1
fi
if [[ -e "$tmp/out" ]]; then
  echo "FAIL: 'rosguard run' left $tmp/out behind"
  status=1
fi
exit $status

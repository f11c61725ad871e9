#!/bin/bash
# The shipped 2-core example runs unchanged on both backends, and `rosguard compare` of the two
# result folders writes its table with every point paired.
# Usage: two_core_both_backends.sh ROSGUARD SOURCE_DIR
set -euo pipefail
rosguard=$1
src=$2
scenario=$src/scenarios/examples/two-core-both-backends.json
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

if [ "$(nproc)" -lt 2 ]; then echo "SKIPPED: the example needs 2 CPUs, this host has $(nproc)"; exit 0; fi
"$rosguard" run "$scenario" --backend sim --out "$tmp/sim" --quiet || fail "sim run"
"$rosguard" run "$scenario" --backend hw --out "$tmp/hw" --quiet || fail "hw run"
for b in sim hw; do
  rows=$(($(wc -l < "$tmp/$b/points.csv") - 1))
  [ "$rows" -eq 8 ] || fail "$b wrote $rows rows, expected 8 (4 thresholds x 2 repetitions)"
  grep -q "\"status\": *\"complete\"" "$tmp/$b/manifest.json" || fail "$b manifest not complete"
done
"$rosguard" compare "$tmp/sim" "$tmp/hw" --out "$tmp/cmp" > "$tmp/compare.txt" || fail "compare"
cat "$tmp/compare.txt"
[ -s "$tmp/cmp/compare.csv" ] || fail "no comparison table"
grep -q "common points: 4; only in A: 0; only in B: 0" "$tmp/compare.txt" || fail "points not paired"
paired=$(($(wc -l < "$tmp/cmp/compare.csv") - 1))
[ "$paired" -ge 4 ] || fail "comparison table has $paired rows, expected at least 4"
echo "ok: sim and hw ran the same scenario; compare paired 4 points ($paired rows)"

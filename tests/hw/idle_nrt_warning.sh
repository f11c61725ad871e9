#!/usr/bin/env bash
# An hw run whose nRT node does none of its work (self-sampling every 1 us leaves it no time)
# exits 0 with an empty nrt_slowdown: a warning says so, on stderr and in manifest.json.
# Usage: idle_nrt_warning.sh ROSGUARD SOURCE_DIR
set -euo pipefail
rosguard=$1 src=$2
[[ $(nproc) -ge 2 ]] || { echo "SKIPPED: needs two CPUs"; exit 0; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
python3 - "$src" "$tmp" <<'PY'
import json, sys
src, tmp = sys.argv[1:]
d = json.load(open(f"{src}/scenarios/examples/two-core-both-backends.json"))
d["$schema"] = f"{src}/scenarios/schema/scenario.schema.json"
d["regulation"]["sampling"] = "self"
d["regulation"]["sampling_period_us"] = 1
d.pop("sweep", None)
d["repetitions"] = 1
json.dump(d, open(f"{tmp}/s.json", "w"))
PY
"$rosguard" run "$tmp/s.json" --backend hw --out "$tmp/r" 2>"$tmp/err" || { cat "$tmp/err"; fail "the run failed"; }
runs=$(python3 -c "import csv; print(csv.DictReader(open('$tmp/r/points.csv')).__next__()['nrt_runs'])")
echo "nrt_runs $runs"
if python3 -c "import sys; sys.exit(float('$runs') > 0)"; then
  grep "did none of its work (nrt_runs 0)" "$tmp/err" || fail "no warning on stderr"
  grep -q "did none of its work" "$tmp/r/manifest.json" || fail "no warning in manifest.json"
  grep -q "samples itself every 1 us" "$tmp/err" || fail "the warning does not name the sampling"
else
  ! grep -q "did none of its work" "$tmp/err" || fail "a warning where the node worked"
  echo "SKIPPED: the nRT node did some work here even at 1 us sampling"
  exit 0
fi
echo "PASS"

#!/bin/bash
# make validate's script on a two-scenario suite: a small valid one and one the loader refuses.
# The valid one runs on hw and in sim, is compared, and lands in report.json / report.md with
# the figure; the refused one is named as failed (exit 1), and the report still lists it.
# Also: `platform: host` without a host model and without `rosguard calibrate` stops with a
# message saying so. No timing is checked.
# Usage: validate_suite.sh ROSGUARD SOURCE_DIR
set -euo pipefail
rosguard=$1
src=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

if [ "$(nproc)" -lt 2 ]; then
  echo "SKIPPED: the suite needs 2 CPUs, this host has $(nproc)"
  exit 0
fi
mkdir "$tmp/suite"
# Small: 2 thresholds x 2 repetitions, one RT job.
/usr/bin/python3 - "$src/scenarios/validation/interval-self-thresholds.json" "$tmp/suite" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
d["name"] = "small"
d["repetitions"] = 2
for key in ("precision_pct", "max_repetitions"):  # fixed repetitions: a short, bounded test
    d["hw"].pop(key, None)
d["nodes"]["rt"][0]["iterations"] = 1
d["sweep"] = {"regulation.threshold_pct": [20, 80]}
d.pop("$schema")
open(sys.argv[2] + "/small.json", "w").write(json.dumps(d))
d["name"] = "broken"
d["regulation"]["no_such_key"] = 1
open(sys.argv[2] + "/broken.json", "w").write(json.dumps(d))
PY

set +e
# The platform pinned: with the script's default `host`, a machine without a host model would
# calibrate (minutes, and an install into the user's data folder) inside a test.
ROSGUARD_VALIDATE_PLATFORM=vm-2core ROSGUARD_VALIDATE_SUITE=$tmp/suite \
  ROSGUARD_VALIDATE_OUT=$tmp/out "$src/tools/validate.sh" "$rosguard" > "$tmp/log" 2>&1
code=$?
set -e
cat "$tmp/log"
[ "$code" -eq 1 ] || fail "exit status $code with a failing scenario, expected 1"
grep -q '^\[1/2\] broken .* hw FAILED' "$tmp/log" || fail "the failed scenario is not named"
grep -q "1 scenario(s) failed: broken" "$tmp/log" || fail "no failure summary"
grep -Eq '^\[2/2\] small +hw +[0-9.]+ s sim +[0-9.]+ s +RT MAPE' "$tmp/log" \
  || fail "no progress line for the scenario that ran"
for f in report.json report.md validation_scatter.png validation_scatter.pdf \
         compare/small/compare.csv hw/small/points.csv sim/small/points.csv; do
  [ -s "$tmp/out/$f" ] || fail "$f not written"
done
/usr/bin/python3 - "$tmp/out/report.json" <<'PY' || fail "report.json content"
import json, sys
r = json.load(open(sys.argv[1]))
assert [s["name"] for s in r["scenarios"]] == ["small"], r["scenarios"]
assert r["scenarios"][0]["common_points"] == 2
assert r["overall"]["rt"]["pairs"] == 2 and r["overall"]["nrt"]["pairs"] == 2
assert [f["scenario"] for f in r["failed"]] == ["broken"]
assert set(r["overall"]["goals"]) == {"rt_mape", "nrt_mape", "rt_excess", "nrt_excess"}
assert r["platform"] == {"hw": "vm-2core", "sim": "vm-2core"}
assert "load average" in r["notes"][0]
PY
grep -q "| small | 2 |" "$tmp/out/report.md" || fail "report.md has no row for the scenario"

if "$rosguard" --help 2>/dev/null | grep -E '^ +calibrate +' >/dev/null; then
  echo "ok: suite (the host-model guard is not checked: this rosguard has 'calibrate')"
  exit 0
fi
set +e
ROSGUARD_VALIDATE_PLATFORM=host ROSGUARD_HOST_MODEL=$tmp/none.json \
  ROSGUARD_VALIDATE_SUITE=$tmp/suite ROSGUARD_VALIDATE_OUT=$tmp/out2 \
  "$src/tools/validate.sh" "$rosguard" > "$tmp/log2" 2>&1
code=$?
set -e
cat "$tmp/log2"
[ "$code" -eq 1 ] || fail "host without a model or calibrate: exit $code, expected 1"
grep -q "no host model at $tmp/none.json.*no 'calibrate' command" "$tmp/log2" \
  || fail "no message about the missing calibrate command"
[ ! -e "$tmp/out2" ] || fail "results written although nothing could run"
echo "ok: suite ran, the failed scenario was named, the report written; host guard works"

#!/bin/bash
# make validate's prediction band (tools/validate.sh, issue 22): with band platforms beside the
# host model (band/*.json, as `rosguard calibrate --install` writes them for prior-dominated
# parameters), each scenario also runs in sim on every band platform into
# OUT/sim-band/<variant>/<scenario>/, the console says how many band runs and how long, compare
# and the report get the band; a band run that fails is named and the band made from the others;
# a stale OUT/sim-band is removed; without a band folder, or with one older than the model,
# there is no band. Stand-ins: `rosguard platform model` says the model is of this machine,
# `rosguard platform contention` that it is in the model's state (contention_stand_in.sh) and
# `rosguard run --backend hw` runs sim (no hw, no second CPU, no calibration); everything else is
# the real rosguard. The model is vm-2core; the band moves its L3 queue x/ 3.
# Usage: validate_band.sh ROSGUARD SOURCE_DIR
set -euo pipefail
real=$(realpath "$1")
src=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

bash "$src/tests/app/rosguard_stand_in.sh" "$real" "$src" "$tmp/rosguard"

mkdir -p "$tmp/suite" "$tmp/host/band"
/usr/bin/python3 - "$src" "$tmp" <<'PY'
import json, sys
src, tmp = sys.argv[1:]
d = json.load(open(f"{src}/scenarios/validation/interval-self-thresholds.json"))
d["name"] = "small"
d["repetitions"] = 2
d["nodes"]["rt"][0]["iterations"] = 1
d["sweep"] = {"regulation.threshold_pct": [20, 80]}
d.pop("$schema")
open(f"{tmp}/suite/small.json", "w").write(json.dumps(d))
p = json.load(open(f"{src}/scenarios/platforms/vm-2core.json"))
p.pop("$schema", None)
p["name"] = "host"
open(f"{tmp}/host/platform.json", "w").write(json.dumps(p))
for side, factor in (("low", 1 / 3), ("high", 3.0)):
    q = json.loads(json.dumps(p))
    q["name"] = f"host-l3.queue_ns-{side}"
    q["memory"]["l3"]["queue_ns"] *= factor
    open(f"{tmp}/host/band/host-l3.queue_ns-{side}.json", "w").write(json.dumps(q))
PY
# A band platform the loader refuses: its run fails, the band is made from the other two.
echo '{"name": "host-broken-high"}' >"$tmp/host/band/host-broken-high.json"

validate() {  # $1: case name; sets $log, $code
  log=$tmp/$1.log
  code=0
  ROSGUARD_VALIDATE_PLATFORM=host ROSGUARD_HOST_MODEL=$tmp/host/platform.json \
    ROSGUARD_VALIDATE_SUITE=$tmp/suite ROSGUARD_VALIDATE_OUT=$tmp/out \
    "$src/tools/validate.sh" "$tmp/rosguard" >"$log" 2>&1 || code=$?
  cat "$log"
}

mkdir -p "$tmp/out/sim-band/stale-variant/small"
validate band
[ "$code" -eq 0 ] || fail "band: exit $code, expected 0 (a failed band run is a warning)"
grep -q "prediction band: the host model has 3 band platform(s) in $tmp/host/band/" "$log" ||
  fail "band: the band platforms are not announced"
grep -Eq '^\[1/1\] small +hw +[0-9.]+ s \(state 1.40x/1.40x, model 1.40x\) sim +[0-9.]+ s band 2 run\(s\) +[0-9]+\.[0-9] s \(1 FAILED\) +RT MAPE [0-9.]+ % +nRT MAPE [0-9.]+ %$' \
  "$log" || fail "band: no band runs on the progress line (or not as expected)"
grep -Eq "prediction band: 2 band run\(s\) on 3 platform\(s\) in [0-9]+\.[0-9] s" "$log" ||
  fail "band: no band summary"
grep -q "warning: a band run failed: small on host-broken-high" "$log" ||
  fail "band: the failed band run is not named"
[ ! -e "$tmp/out/sim-band/stale-variant" ] || fail "band: the stale sim-band folder was kept"
for side in low high; do
  folder=$tmp/out/sim-band/host-l3.queue_ns-$side/small
  [ -s "$folder/points.csv" ] || fail "band: no run on the $side band platform"
  grep -q "host-l3.queue_ns-$side" "$folder/manifest.json" ||
    fail "band: the $side run's manifest does not name its band platform"
done
/usr/bin/python3 - "$tmp/out" <<'PY' || fail "band: report.json / summary.json content"
import json, sys
out = sys.argv[1]
r = json.load(open(f"{out}/report.json"))
band = r["band"]
assert {"host-l3.queue_ns-low", "host-l3.queue_ns-high"} <= set(band["variants"]), band
small = r["scenarios"][0]["band"]
assert small["variants"] == ["host-l3.queue_ns-high", "host-l3.queue_ns-low"], small
for node in ("rt", "nrt"):
    assert band[node]["points"] == 2, band[node]
assert band["nrt"]["median_width"] > 0, band          # the band platforms did move the sim
assert all(p["band_low"] <= p["sim_mean"] <= p["band_high"] for p in r["points"]), r["points"]
s = json.load(open(f"{out}/compare/small/summary.json"))
assert len(s["band"]["folders"]) == 2 and s["band"]["rt"]["points"] == 2, s["band"]
PY
grep -q "## Prediction band" "$tmp/out/report.md" || fail "band: report.md has no band section"
grep -q "B's band covers A at" "$tmp/out/logs/small-compare.log" || fail "band: compare got no band"

# Band files older than the model: of an earlier calibration, not used.
rm "$tmp/host/band/host-broken-high.json"
touch -d '1 hour ago' "$tmp/host/band/"*.json
validate stale
[ "$code" -eq 0 ] || fail "stale: exit $code"
grep -q "is older than the host model .*no prediction band this time" "$log" ||
  fail "stale: no warning"
grep -q "band" <(grep '^\[1/1\]' "$log") && fail "stale: band runs made"
[ ! -e "$tmp/out/sim-band" ] || fail "stale: the previous sim-band folder was kept"
/usr/bin/python3 -c 'import json,sys; assert "band" not in json.load(open(sys.argv[1]))' \
  "$tmp/out/report.json" || fail "stale: the report has a band"

# No band folder: as before.
rm -r "$tmp/host/band"
validate none
[ "$code" -eq 0 ] || fail "none: exit $code"
grep -q "prediction band" "$log" && fail "none: a band is mentioned"
/usr/bin/python3 -c 'import json,sys; assert "band" not in json.load(open(sys.argv[1]))' \
  "$tmp/out/report.json" || fail "none: the report has a band"
grep -q "Prediction band" "$tmp/out/report.md" && fail "none: report.md has a band section"
echo "ok: band runs, their failure named, compare and report with the band; none when stale or absent"

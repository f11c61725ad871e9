#!/bin/bash
# make validate's host-model decision (tools/validate.sh, issue 22): it calibrates when no model
# of THIS machine is installed (none, one measured on another machine, one that does not say, or
# one `rosguard platform model` cannot read) and says why. `rosguard calibrate` is a stand-in
# here (the real one measures for minutes); everything else is the real rosguard. The suite is an
# empty folder, so the script stops right after the decision ("no scenario"). A model of this
# machine is not calibrated again: tests/sim/test_sim_host_model.cpp checks `platform model`'s
# exit 0 for it.
# Usage: validate_host_model.sh ROSGUARD SOURCE_DIR
set -euo pipefail
real=$(realpath "$1")
src=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

cat >"$tmp/rosguard" <<EOF
#!/bin/bash
if [[ \$1 == calibrate ]]; then echo "stand-in: rosguard \$*"; touch "$tmp/calibrated"; exit 0; fi
exec "$real" "\$@"
EOF
chmod +x "$tmp/rosguard"
mkdir "$tmp/suite"

# $1: case name; the model file is $tmp/$1.json (or missing). Sets $log.
validate() {
  rm -f "$tmp/calibrated"
  log=$tmp/$1.log
  local code=0
  ROSGUARD_VALIDATE_PLATFORM=host ROSGUARD_HOST_MODEL=$tmp/$1.json \
    ROSGUARD_VALIDATE_SUITE=$tmp/suite ROSGUARD_VALIDATE_OUT=$tmp/out-$1 \
    "$src/tools/validate.sh" "$tmp/rosguard" >"$log" 2>&1 || code=$?
  cat "$log"
  [ "$code" -eq 1 ] || fail "$1: exit $code, expected 1 (the empty suite)"
  grep -q "no scenario in $tmp/suite" "$log" || fail "$1: did not get past the host model"
}

model() {  # $1: case name, $2: Python that edits the dict d (vm-2core)
  /usr/bin/python3 - "$src/scenarios/platforms/vm-2core.json" "$tmp/$1.json" "$2" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
exec(sys.argv[3])
open(sys.argv[2], "w").write(json.dumps(d))
PY
}

validate none
grep -q "validate: no host model at $tmp/none.json" "$log" || fail "none: no reason given"
grep -q "calibrating this machine (rosguard calibrate --quick --install)" "$log" ||
  fail "none: no calibration announced"
[ -e "$tmp/calibrated" ] || fail "none: calibrate was not run"

model other 'd["measured_on"]["cpu_model"] = "Not This CPU"'
validate other
grep -q "is not a model of this machine" "$log" || fail "other: no reason given"
grep -q "CPU model 'Not This CPU' (model) vs" "$log" || fail "other: the difference is not named"
[ -e "$tmp/calibrated" ] || fail "other: calibrate was not run"

model unknown 'd.pop("measured_on")'
validate unknown
grep -q "does not record the machine it was measured on" "$log" || fail "unknown: no reason given"
[ -e "$tmp/calibrated" ] || fail "unknown: calibrate was not run"

echo '{"name": "host"}' >"$tmp/invalid.json"
validate invalid
grep -q "could not read the host model at $tmp/invalid.json (exit 2)" "$log" ||
  fail "invalid: no reason given"
[ -e "$tmp/calibrated" ] || fail "invalid: calibrate was not run"
echo "ok: calibrated, with the reason, for no model, another machine, an unknown one, a bad file"

#!/bin/bash
# make validate and the machine's DRAM-interference state (tools/validate.sh, issue 22): a host
# model that records no state is calibrated again; each hw run waits for the model's state
# (bounded by ROSGUARD_VALIDATE_STATE_WAIT_S), is probed after and taken once more when the state
# changed during it; $out/state/<scenario>.json and the report say so. Stand-ins: `rosguard
# platform model` says the model is of this machine, `rosguard platform contention` answers from
# a list of states (contention_stand_in.sh), `rosguard calibrate` only leaves a mark, `rosguard
# run --backend hw` runs sim; everything else is the real rosguard, on vm-2core.
# Usage: validate_state.sh ROSGUARD SOURCE_DIR
set -euo pipefail
real=$(realpath "$1")
src=$(realpath "$2")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

bash "$src/tests/app/rosguard_stand_in.sh" "$real" "$src" "$tmp/rosguard" "$tmp/calibrated"
cp "$src/scenarios/platforms/vm-2core.json" "$tmp/host.json"
export ROSGUARD_HOST_MODEL=$tmp/host.json
mkdir -p "$tmp/suite" "$tmp/empty"
cp "$src/scenarios/validation/corun-unregulated.json" "$tmp/suite/"

# $1: case, $2: suite folder, $3...: the states, one per probe ("RATIO MODEL_RATIO [REVERSE]");
# sets $log and $code.
validate() {
  local name=$1 suite=$2
  shift 2
  printf '%s\n' "$@" >"$tmp/$name.states"
  rm -f "$tmp/calibrated"
  log=$tmp/$name.log
  code=0
  ROSGUARD_TEST_STATES=$tmp/$name.states ROSGUARD_VALIDATE_SUITE=$suite \
    ROSGUARD_VALIDATE_OUT=$tmp/out-$name ROSGUARD_VALIDATE_CPUS=2 \
    "$src/tools/validate.sh" "$tmp/rosguard" >"$log" 2>&1 || code=$?
  cat "$log"
}
state() {  # $1: case; prints the scenario's state file as "before after waited attempts"
  /usr/bin/python3 -c 'import json,sys; d=json.load(open(sys.argv[1]))
print(d["before"]["ratio"], d["after"]["ratio"], d["waited_s"], d["attempts"])' \
    "$tmp/out-$1/state/corun-unregulated.json"
}

# 1. A model that records no state: calibrated again, and says why.
validate stateless "$tmp/empty" "1.40 none"
[ "$code" -eq 1 ] && grep -q "no scenario in $tmp/empty" "$log" || fail "stateless: exit $code"
grep -q "does not record the DRAM-interference state it was calibrated in" "$log" ||
  fail "stateless: no reason given"
[ -e "$tmp/calibrated" ] || fail "stateless: calibrate was not run"

# 2. A model in another state now: not calibrated again (each run waits instead).
validate elsewhere "$tmp/empty" "1.02 1.40"
[ "$code" -eq 1 ] || fail "elsewhere: exit $code"
[ ! -e "$tmp/calibrated" ] || fail "elsewhere: calibrated, though the model records its state"

# 3. In the model's state throughout: one run, no wait.
validate steady "$tmp/suite" "1.40 1.40"
[ "$code" -eq 0 ] || fail "steady: exit $code"
grep -qE "corun-unregulated +hw +[0-9.]+ s \(state 1.40x/1.40x, model 1.40x\)" "$log" ||
  fail "steady: the console does not show the state"
[ "$(state steady)" == "1.4 1.4 0.0 1" ] || fail "steady: state $(state steady)"
grep -q "1 of 1 scenarios measured in the model's DRAM-interference state" \
  "$tmp/out-steady/report.md" || fail "steady: the report does not say so"

# 4. Another state at first (the start's probe and the run's first two), then the model's; after
# the run another again: taken once more, in the model's state throughout.
validate moved "$tmp/suite" "1.02 1.40" "1.02 1.40" "1.02 1.40" "1.42 1.40" "1.75 1.40" \
  "1.38 1.40" "1.41 1.40"
[ "$code" -eq 0 ] || fail "moved: exit $code"
read -r before after waited attempts <<<"$(state moved)"
[ "$before $after $attempts" == "1.38 1.41 2" ] || fail "moved: state $(state moved)"
/usr/bin/python3 -c "import sys; sys.exit(not 10 <= $waited < 30)" ||
  fail "moved: waited $waited s, expected two waits of 5 s"
grep -qE "\(state 1.38x/1.41x, model 1.40x; waited [0-9]+ s; run twice\)" "$log" ||
  fail "moved: the console does not say it waited and ran twice"

# 5. No time to wait (ROSGUARD_VALIDATE_STATE_WAIT_S=0) and no calibrating again: one run in
# another state, and the report says so.
ROSGUARD_VALIDATE_STATE_WAIT_S=0 ROSGUARD_VALIDATE_RECALIBRATE=0 \
  validate nowait "$tmp/suite" "1.02 1.40"
[ "$code" -eq 0 ] || fail "nowait: exit $code"
[ "$(state nowait)" == "1.02 1.02 0.0 1" ] || fail "nowait: state $(state nowait)"
grep -q "1.02x / 1.02x, model 1.40x: differs" "$tmp/out-nowait/report.md" ||
  fail "nowait: the report does not mark the state"
grep -q "In another state: corun-unregulated" "$tmp/out-nowait/report.md" ||
  fail "nowait: the report does not name the scenario"

# 6. A bad wait or count: refused before anything runs.
ROSGUARD_VALIDATE_STATE_WAIT_S=soon validate badwait "$tmp/suite" "1.40 1.40"
[ "$code" -eq 1 ] && grep -q "ROSGUARD_VALIDATE_STATE_WAIT_S='soon' is not a number" "$log" ||
  fail "badwait: exit $code"
ROSGUARD_VALIDATE_RECALIBRATE=-1 validate badcount "$tmp/suite" "1.40 1.40"
[ "$code" -eq 1 ] && grep -q "ROSGUARD_VALIDATE_RECALIBRATE='-1' is not a count" "$log" ||
  fail "badcount: exit $code"
[ ! -e "$tmp/calibrated" ] || fail "badcount: calibrated"

# 7. Another state past the wait (none here): calibrated again before the run, which then runs
# in the new model's state; the console, the state file, the summary and the report say so.
ROSGUARD_VALIDATE_STATE_WAIT_S=0 validate again "$tmp/suite" "1.02 1.40" "1.02 1.40" \
  "1.02 1.02" "1.03 1.02"
[ "$code" -eq 0 ] || fail "again: exit $code"
[ -e "$tmp/calibrated" ] || fail "again: not calibrated again"
[ "$(state again)" == "1.02 1.03 0.0 1" ] || fail "again: state $(state again)"
grep -qE "\(state 1.02x/1.03x, model 1.02x; calibrated again\)" "$log" ||
  fail "again: the console does not say it calibrated again"
grep -q "validate: calibrated again before corun-unregulated" "$log" ||
  fail "again: no summary line"
grep -q "calibrated again (quick) before corun-unregulated" "$tmp/out-again/report.md" ||
  fail "again: the report does not say so"
/usr/bin/python3 -c 'import json,sys; sys.exit(not json.load(open(sys.argv[1]))["recalibrated"])' \
  "$tmp/out-again/state/corun-unregulated.json" || fail "again: the state file does not say so"

# 8. The two CPUs not slowed alike (the other way round 1.05x) before the run, alike after: the
# console says so, with the other way's ratio.
validate unlike "$tmp/suite" "1.40 1.40" "1.40 1.40 1.05" "1.40 1.40"
[ "$code" -eq 0 ] || fail "unlike: exit $code"
grep -qE "\(state 1.40x/1.40x, model 1.40x; the CPUs not slowed alike: the other way 1.05x\)" \
  "$log" || fail "unlike: the console does not say the CPUs were not slowed alike"
echo "PASS"

#!/bin/bash
# The scale validation (issue 24): scenarios/validation/scale/ is tools/scale_scenarios.py's
# output; every scale scenario passes `rosguard check` on a 16-core host model; make validate
# (tools/validate.sh) runs the k = 1 ones on a host of 2 CPUs and skips the others, each with its
# reason (console and report), and on a host of 6 CPUs also runs the generated k = N - 2 = 4.
# The CPU count is faked (ROSGUARD_VALIDATE_CPUS); a run without the analysis's Python modules
# (faked: ROSGUARD_VALIDATE_ANALYSIS=0) runs the scenarios only, and --report reports them later.
# Stand-ins: `rosguard platform model` says the model is of this machine, `rosguard platform
# contention` that it is in the model's state (contention_stand_in.sh) and `rosguard run
# --backend hw` runs sim (no hw here); everything else is the real rosguard. The host model is vm-2core with 16 cores in its cluster.
# Usage: validate_scale.sh ROSGUARD SOURCE_DIR
set -euo pipefail
real=$(realpath "$1")
src=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
py() { PYTHONPATH="$src" /usr/bin/python3 "$@"; }

# 1. The shipped files are the generator's output.
py "$src/tools/scale_scenarios.py" --out "$tmp/generated" >/dev/null
py - "$src/scenarios/validation/scale" "$tmp/generated" <<'PY' || fail "scenarios/validation/scale/ differs from tools/scale_scenarios.py's output; run it"
import json, sys
from pathlib import Path
shipped, generated = (Path(p) for p in sys.argv[1:])
names = sorted(p.name for p in shipped.glob("*.json"))
assert names == sorted(p.name for p in generated.glob("*.json")), names
for name in names:
    a, b = (json.loads((d / name).read_text()) for d in (shipped, generated))
    a.pop("$schema"); b.pop("$schema")
    assert a == b, name
print(f"{len(names)} scale scenarios, as generated")
PY

# The host model: vm-2core, 16 cores.
py - "$src/scenarios/platforms/vm-2core.json" "$tmp/host16.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
d["cpu"]["cores_per_cluster"] = 16
open(sys.argv[2], "w").write(json.dumps(d))
PY
export ROSGUARD_HOST_MODEL=$tmp/host16.json

# 2. rosguard check: every scale scenario, in sim on the 16-core model; the working sets sized.
for f in "$src"/scenarios/validation/scale/*.json; do
  "$real" check "$f" --backend sim >"$tmp/check.log" 2>&1 ||
    { cat "$tmp/check.log"; fail "rosguard check $f failed"; }
done
py - "$src" <<'PY' || fail "the scale scenarios do not size their working sets as documented"
import json, sys
from pathlib import Path
src = Path(sys.argv[1])
for name, cache, times in (("bandwidth_read_llc", "l2", 4), ("bandwidth_read_dram", "l3", 2)):
    hw = json.loads((src / "scenarios" / "workloads" / f"{name}.json").read_text())["hw"]
    assert hw["working_set"] == {"cache": cache, "times": times}, (name, hw)
print("working sets: 4 x L2 (LLC-bound), 2 x L3 (DRAM-bound)")
PY

# 3. make validate on a host of 2 CPUs: the k = 1 scenarios run, the others are skipped.
bash "$src/tests/app/rosguard_stand_in.sh" "$real" "$src" "$tmp/rosguard"
mkdir -p "$tmp/suite"
cp -r "$src/scenarios/validation/scale" "$tmp/suite/scale"

validate() {  # $1: CPUs, $2: out folder; sets $log
  log=$2.log
  local code=0
  ROSGUARD_VALIDATE_CPUS=$1 ROSGUARD_VALIDATE_SUITE=$tmp/suite ROSGUARD_VALIDATE_OUT=$2 \
    "$src/tools/validate.sh" "$tmp/rosguard" >"$log" 2>&1 || code=$?
  cat "$log"
  [ "$code" -eq 0 ] || fail "validate.sh with $1 CPUs: exit $code"
}

validate 2 "$tmp/out2"
for k in 1; do
  for ws in llc dram; do
    grep -qE "scale-k$k-$ws +hw +[0-9.]+ s \(state 1.40x/1.40x, model 1.40x\) +sim" "$log" ||
      fail "scale-k$k-$ws did not run, or not with its machine state"
    [ -f "$tmp/out2/hw/scale-k$k-$ws/points.csv" ] || fail "no hw results of scale-k$k-$ws"
    [ -f "$tmp/out2/state/scale-k$k-$ws.json" ] || fail "no machine state of scale-k$k-$ws"
  done
done
for k in 3 7 14; do
  for ws in llc dram; do
    grep -q "scale-k$k-$ws  *skipped: needs $((k + 1)) CPUs (cores 0-$k), this host has 2" "$log" ||
      fail "scale-k$k-$ws was not skipped with its reason"
    grep -q -- "- \*\*scale-k$k-$ws\*\*: needs $((k + 1)) CPUs (cores 0-$k), this host has 2" \
      "$tmp/out2/report.md" || fail "the report does not list scale-k$k-$ws as skipped"
  done
done
grep -q "6 scenario(s) skipped" "$log" || fail "no count of the skipped scenarios"
py - "$tmp/out2/report.json" <<'PY' || fail "the report's errors per k"
import json, sys
report = json.load(open(sys.argv[1]))
rows = report["per_k"]
assert [r["k"] for r in rows] == [1], rows
assert rows[0]["scenarios"] == ["scale-k1-dram", "scale-k1-llc"], rows[0]["scenarios"]
assert rows[0]["points"] == 8 and rows[0]["rt"]["pairs"] == 8, rows[0]
# sim against sim (the stand-in): the same model and seed, no error.
assert rows[0]["rt"]["mape_pct"] == 0 and rows[0]["nrt"]["mape_pct"] == 0, rows[0]
assert len(report["skipped"]) == 6
for s in report["scenarios"]:
    assert s["machine_state"] == {"before": 1.4, "after": 1.4, "model": 1.4, "matches": True,
                                  "waited_s": 0.0, "attempts": 1, "alike": True,
                                  "other_way": 1.4, "speed_before": None,
                                  "speed_after": None}, s["machine_state"]
print("report: k = 1 compared, 6 skipped, each in the model's machine state")
PY

# 4. Without the analysis's Python modules (faked): the runs only, then --report elsewhere.
ROSGUARD_VALIDATE_ANALYSIS=0 validate 2 "$tmp/out-noanalysis"
grep -q "lacks numpy, pandas, matplotlib or scipy" "$log" || fail "no word on the missing modules"
[ ! -e "$tmp/out-noanalysis/report.json" ] || fail "a report without the analysis"
[ -f "$tmp/out-noanalysis/hw/scale-k1-llc/points.csv" ] || fail "no runs without the analysis"
mv "$tmp/out-noanalysis" "$tmp/copied"
code=0
ROSGUARD_VALIDATE_OUT=$tmp/copied "$src/tools/validate.sh" --report "$tmp/rosguard" \
  >"$tmp/report.log" 2>&1 || code=$?
cat "$tmp/report.log"
[ "$code" -eq 0 ] || fail "validate.sh --report: exit $code"
grep -qE "^scale-k1-llc +RT MAPE" "$tmp/report.log" || fail "--report did not compare"
py - "$tmp/copied/report.json" <<'PY' || fail "--report's report"
import json, sys
report = json.load(open(sys.argv[1]))
assert [r["k"] for r in report["per_k"]] == [1] and len(report["skipped"]) == 6, report
PY

# 5. A host of 6 CPUs: k = 3 runs too, and k = N - 2 = 4 is generated and run.
rm -rf "$tmp/suite/scale"/scale-k{7,14}-*.json "$tmp/suite/scale"/scale-k1-*.json
validate 6 "$tmp/out6"
grep -q "this host has 6 CPUs: the scale scenarios of k = 4 co-runners too" "$log" ||
  fail "k = N - 2 was not announced"
py - "$tmp/out6/report.json" <<'PY' || fail "k = 3 and the generated k = 4 were not compared"
import json, sys
report = json.load(open(sys.argv[1]))
assert [r["k"] for r in report["per_k"]] == [3, 4], report["per_k"]
assert report["per_k"][1]["scenarios"] == ["scale-k4-dram", "scale-k4-llc"]
assert not report["skipped"]
print("6 CPUs: k = 3 and 4 compared")
PY
echo "PASS"

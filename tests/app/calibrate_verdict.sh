#!/usr/bin/env bash
# rosguard calibrate ends with a verdict against the validation goals and the command to run next
# (issue 53, item 5). It refits the development VM's measurements (--from
# tests/sim/fixtures/calibration-vm.json, as tests/sim/test_sim_calibrate.cpp does; nothing is
# measured) and checks:
# - the last two lines are "verdict: ..." with the goals of analysis/goals.json (the file make
#   validate's report reads) and the co-run slowdown errors recomputed here from
#   calibration.json's fit, and "next: ..." naming what was written;
# - the next command, run as printed from a folder with nothing in it, works: without --install it
#   is `calibrate --from OUT/calibration.json --install`, whose own next command (a scenario with
#   "platform": "host" in sim) then runs too.
# Usage: calibrate_verdict.sh ROSGUARD SOURCE_DIR
set -euo pipefail
rosguard=$1 src=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
export ROSGUARD_HOST_MODEL=$tmp/model/platform.json MPLBACKEND=Agg
export PATH=$(dirname "$rosguard"):$PATH  # the next commands name `rosguard`
mkdir "$tmp/work"
cd "$tmp/work"

"$rosguard" calibrate --from "$src/tests/sim/fixtures/calibration-vm.json" --out "$tmp/cal" \
  >"$tmp/out" 2>"$tmp/err" || { cat "$tmp/out" "$tmp/err"; fail "calibrate --from exited $?"; }
tail -n 2 "$tmp/out"
verdict=$(tail -n 2 "$tmp/out" | head -n 1)
next=$(tail -n 1 "$tmp/out")

# The goals and the errors, computed from the files (not from rosguard's code).
expected=$(/usr/bin/python3 - "$src/analysis/goals.json" "$tmp/cal/calibration.json" <<'EOF'
import json, sys
goals = json.load(open(sys.argv[1]))
bound = {(g["node"], g["metric"]): g["bound_pct"] for g in goals["goals"].values()}
fmt = lambda v, p=3: f"{v:.{p}g}"
print(f"slowdown MAPE <= {fmt(bound['rt', 'mape_pct'])} % (RT), "
      f"<= {fmt(bound['nrt', 'mape_pct'])} % (nRT), "
      f"excess error <= {fmt(max(bound['rt', 'excess_error_pct'], bound['nrt', 'excess_error_pct']))} %")
cal = json.load(open(sys.argv[2]))
runs = cal["measurements"]["runs"]
fitted = [r for r in cal["fit"]["runs"] if r["used"]]
alone = {(runs[r["index"]]["kernel"], runs[r["index"]]["working_set_kb"]): r
         for r in fitted if not runs[r["index"]]["corunners"]}
errors, excess = [], []
for r in fitted:
    run = runs[r["index"]]
    a = alone.get((run["kernel"], run["working_set_kb"]))
    if not run["corunners"] or a is None:
        continue
    s_hw = r["measured_ns"] / a["measured_ns"]
    s_sim = r["predicted_ns"] / a["predicted_ns"]
    errors.append(abs(s_sim - s_hw) / s_hw)
    if s_hw - 1 >= goals["excess_min"]:
        excess.append(abs(s_sim - s_hw) / (s_hw - 1))
print(f"({len(errors)} co-runs, each over its kernel alone) are off by a MAPE of "
      f"{fmt(100 * sum(errors) / len(errors), 2)} %")
if excess:
    print(f"an excess error of {fmt(100 * sum(excess) / len(excess))} % over {len(excess)} ")
EOF
)
echo "expected in the verdict:"
echo "$expected"
[[ $verdict == "verdict: "* ]] || fail "the second-last line is no verdict: $verdict"
while IFS= read -r part; do
  [[ $verdict == *"$part"* ]] || fail "the verdict lacks '$part'"
done <<<"$expected"
[[ $verdict =~ ^verdict:\ (within|outside) ]] || fail "the verdict says neither within nor outside"

[[ $next == "next: rosguard calibrate --from $tmp/cal/calibration.json --out $tmp/cal --install "* ]] ||
  fail "the last line is not the next command (calibrate --from ... --install): $next"
grep -qF "\"platform\": \"$tmp/cal/platform.json\"" <<<"$next" ||
  fail "the next line does not name the platform file to use in a scenario"

# Run what it says to run next, as printed (the text before the first run of spaces).
command=$(sed -E 's/^next: //; s/   .*$//' <<<"$next")
echo "next: $command"
bash -c "$command" >"$tmp/out2" 2>"$tmp/err2" || { cat "$tmp/out2" "$tmp/err2"; fail "$command"; }
[[ -s $ROSGUARD_HOST_MODEL ]] || fail "the next command did not install the host model"
next2=$(tail -n 1 "$tmp/out2")
tail -n 2 "$tmp/out2"
[[ $(tail -n 2 "$tmp/out2" | head -n 1) == "verdict: "* ]] || fail "no verdict after --install"
[[ $next2 == "next: rosguard run scenarios/examples/host.json --backend sim "* ]] ||
  fail "after --install, the next command is not a run on the host model: $next2"
command=$(sed -E 's/^next: //; s/   .*$//' <<<"$next2")
bash -c "$command" >"$tmp/out3" 2>&1 ||
  { cat "$tmp/out3"; fail "$command"; }
echo "next: $command: $(tail -n 1 "$tmp/out3")"
[[ -s results/host/points.csv ]] || fail "$command wrote no results/host/points.csv"
echo "calibrate's verdict and next commands hold"

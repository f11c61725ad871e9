#!/usr/bin/env bash
# make validate: the sim-vs-hw validation suite (scenarios/validation/, held out from the
# calibration). Runs every scenario with --backend hw and with --backend sim into
# results/validation/{hw,sim}/<scenario>/, compares each pair (rosguard compare ->
# results/validation/compare/<scenario>/), and writes results/validation/report.md,
# report.json and validation_scatter.png/pdf (python3 -m analysis validate).
# The prediction band: when the host model has an uncertainty band (band/ beside it: platforms
# with one prior-dominated parameter one standard error down or up, written by `rosguard
# calibrate --install`), each scenario also runs in sim on every band platform into
# results/validation/sim-band/<variant>/<scenario>/, and compare and the report show the band.
#
# The scale scenarios (scenarios/validation/scale/, tools/scale_scenarios.py: an RT node and k
# co-runners, k = 1, 3, 7, 14, over LLC- and DRAM-bound working sets sized from this host's
# caches) run with the others where this host has the CPUs they name (cores 0..k); the others
# are skipped, each with its reason, in the console and the report. A host with more than 16
# CPUs also runs k = N - 2 (N: its CPUs), generated into results/validation/scenarios/. On a
# 16-CPU host the scale scenarios take some 3-5 minutes (k = 14 the most: 15 DRAM-bound
# kernels of 2 x L3 each).
#
# Without the analysis's Python modules (numpy, pandas, matplotlib, scipy: a lent machine with
# none installed) the script runs every scenario on both backends, then says so and stops before
# compare and the report; `tools/validate.sh --report` on a machine with them (the results
# folder copied there, suite.state included) compares and reports.
#
# Usage: tools/validate.sh [ROSGUARD]      run the suite (default ROSGUARD: build/rosguard)
#        tools/validate.sh --report [ROSGUARD]
#                                          compare and report the runs in the results folder
#                                          (after a run without the analysis's modules)
#        tools/validate.sh --readme        regenerate README.md's validation block and
#                                          docs/figures/validation_scatter.* from the last report
# Environment (for one run; tests use them): ROSGUARD_VALIDATE_PLATFORM overrides the platform
# below, ROSGUARD_VALIDATE_SUITE the scenario folder, ROSGUARD_VALIDATE_OUT the results folder,
# ROSGUARD_VALIDATE_CPUS the CPUs this host is taken to have (default: nproc, the usable ones),
# ROSGUARD_VALIDATE_ANALYSIS=0 runs as if the analysis's Python modules were missing.
set -euo pipefail
cd "$(dirname "$0")/.."

# The platform both backends run: `host` (hw: this machine, probed at run time; sim: the
# calibrated model that `rosguard calibrate --install` saved, made here when missing).
PLATFORM=host
platform=${ROSGUARD_VALIDATE_PLATFORM:-$PLATFORM}

suite=${ROSGUARD_VALIDATE_SUITE:-scenarios/validation}
out=${ROSGUARD_VALIDATE_OUT:-results/validation}
py() { PYTHONPATH="$PWD" /usr/bin/python3 "$@"; }

if [[ ${1:-} == --readme ]]; then
  py -m analysis validate-table "$out/report.json" --readme README.md --figure-dir docs/figures
  exit 0
fi
report_only=0
if [[ ${1:-} == --report ]]; then
  report_only=1
  shift
fi
rosguard=${1:-build/rosguard}
if [[ ! -x $rosguard ]]; then
  echo "validate: $rosguard not found; build first (make build)" >&2
  exit 1
fi
shopt -s nullglob
analysis=${ROSGUARD_VALIDATE_ANALYSIS:-1}
py -c 'import numpy, pandas, matplotlib, scipy' 2>/dev/null || analysis=0

# rosguard compare of scenario $1's hw and sim runs (with its band runs, where compare takes
# them): adds it to ok, or to failed, and prints its MAPEs.
compare_one() {
  local name=$1 band_args=() d
  if ((band_compare)); then
    for d in "$out"/sim-band/*/"$name"; do band_args+=(--band "$d"); done
  fi
  if ! "$rosguard" compare "$out/hw/$name" "$out/sim/$name" --out "$out/compare/$name" \
       "${band_args[@]}" > "$out/logs/$name-compare.log" 2>&1; then
    echo " compare FAILED (see $out/logs/$name-compare.log)"
    failed+=("$name=rosguard compare failed; see $out/logs/$name-compare.log")
    return
  fi
  ok+=("$name")
  # compare's summary rows: "RT  pairs  MAPE ..." (not its band lines: "RT   B's band ...")
  awk '/^(RT|nRT) +[0-9]+ / { printf "  %s MAPE %s %%", $1, $3 }' "$out/logs/$name-compare.log"
  echo
}

# The report of the compared scenarios (ok), the failed and the skipped ones.
write_report() {
  local args f
  args=(-m analysis validate "$out/hw" "$out/sim" --out "$out" ${cpu:+--cpu "$cpu"}
        --scenarios "$(IFS=,; echo "${ok[*]}")"
        --note "1-min load average $load_start at the start, $load_end at the end ($cpus CPUs)")
  if ((${#recalibrated[@]})); then
    args+=(--note "calibrated again (quick) before ${recalibrated[*]}: the host stayed in another\
 DRAM-interference state than the model's; each scenario is compared with the model installed\
 when it ran")
  fi
  for f in "${failed[@]}"; do args+=(--failed "$f"); done
  for f in "${skipped[@]}"; do args+=(--skipped "$f"); done
  if ((band_runs)); then args+=(--band-root "$out/sim-band"); fi
  py "${args[@]}"
  if ((${#failed[@]})); then
    echo "validate: ${#failed[@]} scenario(s) failed: ${failed[*]%%=*}" >&2
    exit 1
  fi
  echo "validate: README block: tools/validate.sh --readme (make validate-readme)"
}

if ((report_only)); then
  if ((!analysis)); then
    echo "validate: --report needs python3 with numpy, pandas, matplotlib and scipy" >&2
    exit 1
  fi
  if [[ ! -f $out/suite.state ]]; then
    echo "validate: no $out/suite.state: run the suite first (tools/validate.sh)" >&2
    exit 1
  fi
  # runs_ok (the scenarios whose runs succeeded), failed, skipped, cpu, cpus, load_start, load_end,
  # band_runs, band_compare, recalibrated, as the run left them (older runs lack recalibrated).
  recalibrated=()
  source "$out/suite.state"
  ok=()
  for name in "${runs_ok[@]}"; do
    printf '%-26s' "$name"
    compare_one "$name"
  done
  write_report
  exit 0
fi

# Field $2 of JSON file $1 as Python prints it ("None" for null).
json_field() {
  py -c 'import json,sys; print(json.load(open(sys.argv[1])).get(sys.argv[2]))' "$1" "$2"
}

# Each hw run waits for the host model's DRAM-interference state (probing every 5 s, at most
# state_wait_each seconds per scenario and ROSGUARD_VALIDATE_STATE_WAIT_S over the whole suite,
# default 300), is probed again after, and is taken once more when the state changed during it;
# $out/state/<scenario>.json records the probes (before, after), the wait and the attempts, and
# the report shows them. When the host stays in another state past the wait, validate calibrates
# again (quick, installed) at most ROSGUARD_VALIDATE_RECALIBRATE times (default 2), so that the
# scenario and those after it are compared with a model of the state they run in: on the VM of
# 2026-11-28 a state held for minutes, and at 10:56 five of eight scenarios ran at 1.6-2.1x
# against a model calibrated at 1.0x once the wait was spent.
state_check=0
if [[ $platform == host ]] &&
   "$rosguard" platform --help 2>/dev/null | grep -E '^ +contention +' >/dev/null; then
  state_check=1
fi
state_wait_left=${ROSGUARD_VALIDATE_STATE_WAIT_S:-300}
if [[ ! $state_wait_left =~ ^[0-9]+$ ]]; then
  echo "validate: ROSGUARD_VALIDATE_STATE_WAIT_S='$state_wait_left' is not a number of seconds" >&2
  exit 1
fi
state_wait_each=60
recalibrations_left=${ROSGUARD_VALIDATE_RECALIBRATE:-2}
if [[ ! $recalibrations_left =~ ^[0-9]+$ ]]; then
  echo "validate: ROSGUARD_VALIDATE_RECALIBRATE='$recalibrations_left' is not a count" >&2
  exit 1
fi
recalibrated=()  # the scenarios before which validate calibrated again

# The sim side of `platform: host` is the installed calibrated model; it must be a model of THIS
# machine. Calibrate (quick) when there is none, or when the installed one was measured on another
# machine or does not say which (`rosguard platform model`: exit 0 this machine, 3 not), and say
# why.
if [[ $platform == host ]]; then
  model=${ROSGUARD_HOST_MODEL:-${XDG_DATA_HOME:-$HOME/.local/share}/rosguard/host/platform.json}
  why=""
  if [[ ! -f $model ]]; then
    why="no host model at $model"
  elif "$rosguard" platform --help 2>/dev/null | grep -E '^ +model +' >/dev/null; then
    rc=0
    said=$("$rosguard" platform model 2>&1) || rc=$?
    if ((rc == 3)); then
      why="the host model at $model is not a model of this machine:
$(sed 's/^/  /' <<<"$said")"
    elif ((rc != 0)); then
      why="rosguard platform model could not read the host model at $model (exit $rc):
$(sed 's/^/  /' <<<"$said")"
    fi
  else
    echo "validate: this rosguard cannot tell which machine the host model at $model was" \
         "measured on (no 'rosguard platform model'); using it as it is"
  fi
  # The DRAM-interference state (`rosguard platform contention`: a DRAM-bound reader alone and
  # beside one on the other CPU, about a second). Under a hypervisor it changes over minutes on
  # the same machine (docs/validation.md), and the model describes the state it was calibrated
  # in; a model that does not record its state is calibrated again.
  if [[ -z $why ]] && ((state_check)); then
    mkdir -p "$out/state"
    "$rosguard" platform contention --out "$out/state/start.json" >/dev/null 2>&1 || true
    if [[ -f $out/state/start.json ]] && [[ $(json_field "$out/state/start.json" model) == None ]]
    then
      why="the host model at $model does not record the DRAM-interference state it was"
      why+=" calibrated in"
    fi
  fi
  if [[ -n $why ]]; then
    # (`rosguard calibrate --help` is no test: the top-level --help answers an unknown command.)
    if ! "$rosguard" --help 2>/dev/null | grep -E '^ +calibrate +' >/dev/null; then
      echo "validate: $why; and this rosguard has no 'calibrate' command" \
           "to make one; build a rosguard with 'rosguard calibrate', or set PLATFORM in" \
           "tools/validate.sh to a platform file (e.g. vm-2core)" >&2
      exit 1
    fi
    echo "validate: $why"
    echo "validate: calibrating this machine (rosguard calibrate --quick --install)"
    "$rosguard" calibrate --quick --install
  fi
  echo "validate: platform host (sim model: $model)"
else
  echo "validate: platform $platform on both backends"
fi

shopt -s nullglob
scenarios=("$suite"/*.json "$suite"/scale/*.json)
((${#scenarios[@]})) || { echo "validate: no scenario in $suite" >&2; exit 1; }

# The CPUs a scenario may name: this host's usable ones. Beyond the scale suite's largest k, a
# host with more CPUs also runs k = N - 2 (one CPU left to the OS and this script).
cpus=${ROSGUARD_VALIDATE_CPUS:-$(nproc)}
if [[ ! $cpus =~ ^[1-9][0-9]*$ ]]; then
  echo "validate: ROSGUARD_VALIDATE_CPUS='$cpus' is not a CPU count" >&2
  exit 1
fi
if [[ -d $suite/scale ]]; then
  largest=$(py -c 'import json,sys
print(max([len(json.load(open(f))["nodes"]["nrt"]) for f in sys.argv[1:]] or [0]))' \
    "$suite"/scale/*.json)
  if ((cpus - 2 > largest)); then
    rm -rf "$out/scenarios/scale"
    py tools/scale_scenarios.py --k $((cpus - 2)) --out "$out/scenarios/scale" >/dev/null
    scenarios+=("$out"/scenarios/scale/*.json)
    echo "validate: this host has $cpus CPUs: the scale scenarios of k = $((cpus - 2))" \
         "co-runners too ($out/scenarios/scale/)"
  fi
fi

# The host model's uncertainty band: band/*.json beside it (absolute paths: the scenario copies
# that name them live elsewhere). Files older than the model are of an earlier one (calibrate
# writes the model first, then its band): left out, with a warning.
# (Again after a calibration mid-suite: the scenarios after it run on the new model's band.)
band_files=()
load_band_files() {
  band_files=()
  [[ $platform == host ]] || return 0
  band_dir=$(cd "$(dirname "$model")" && pwd)/band
  band_files=("$band_dir"/*.json)
  local f
  for f in "${band_files[@]}"; do
    if [[ $f -ot $model ]]; then
      echo "validate: warning: $f is older than the host model $model (of an earlier" \
           "calibration?); no prediction band this time" >&2
      band_files=()
      break
    fi
  done
}
load_band_files
if ((${#band_files[@]})); then
  echo "validate: prediction band: the host model has ${#band_files[@]} band platform(s) in" \
       "$band_dir/ (prior-dominated parameters one standard error down / up); each scenario" \
       "also runs in sim on each, into $out/sim-band/"
fi
# compare --band needs a rosguard that forwards it. (grep without -q: with pipefail, a grep
# that stops reading early can fail the pipeline by SIGPIPE.)
band_compare=0
if [[ $platform == host ]] && "$rosguard" compare --help 2>&1 | grep -e '--band' >/dev/null; then
  band_compare=1
fi

# A copy of scenario $1 whose "platform" is $2, written to $3.
with_platform() {
  py -c 'import json,sys; d=json.load(open(sys.argv[1])); d["platform"]=sys.argv[2]
d.pop("$schema", None)
open(sys.argv[3],"w").write(json.dumps(d,indent=2,ensure_ascii=False)+"\n")' "$1" "$2" "$3"
}

# Scenario $1's hw run (rosguard run $2 > log $3, exit status in rc) in the model's
# DRAM-interference state, as the comment of state_check says; sets state_text to
# " (state B/A, model M; waited W s; calibrated again; run twice; the CPUs not slowed alike: the
# other way R)": the probes' ratios before and after, the model's, whether it waited (5 s or
# more), calibrated again and ran twice, and the reverse probe's ratio where a probe found the
# two CPUs slowed differently (its "alike": false); then "; speed S/S" when the probes measured
# the host's speed against the model's (the reader alone, % slower or faster).
hw_in_state() {
  local name=$1 file=$2 log=$3 st=$out/state/$1 attempts=0 waited=0 each t0 t1 prc recal=0
  while :; do
    prc=0
    "$rosguard" platform contention --out "$st.before.json" >/dev/null 2>&1 || prc=$?
    # The wait: each 5 s pause and the probe after it, until the model's state or no time left.
    each=0
    while ((prc == 3 && state_wait_left > 0 && each < state_wait_each)) &&
          [[ $(json_field "$st.before.json" model) != None ]]; do
      t0=$(date +%s)
      sleep 5
      prc=0
      "$rosguard" platform contention --out "$st.before.json" >/dev/null 2>&1 || prc=$?
      t1=$(date +%s)
      waited=$((waited + t1 - t0))
      each=$((each + t1 - t0))
      state_wait_left=$((state_wait_left - t1 + t0))
    done
    # Still another state: a model of this one (then probe again against it).
    if ((prc == 3 && recalibrations_left > 0)) &&
       [[ $(json_field "$st.before.json" model) != None ]]; then
      recalibrations_left=$((recalibrations_left - 1))
      if "$rosguard" calibrate --quick --install --quiet \
           > "$out/logs/recalibrate-before-$name.log" 2>&1; then
        recal=1
        recalibrated+=("$name")
        load_band_files
        continue
      fi
      echo " (calibrating again failed: see $out/logs/recalibrate-before-$name.log)" >&2
    fi
    rc=0
    "$rosguard" run "$file" --backend hw --out "$out/hw/$name" --overwrite > "$log" 2>&1 || rc=$?
    attempts=$((attempts + 1))
    ((rc == 0)) || return 0
    prc=0
    "$rosguard" platform contention --out "$st.after.json" >/dev/null 2>&1 || prc=$?
    ((prc == 3 && attempts < 2 && state_wait_left > 0)) || break
    [[ $(json_field "$st.after.json" model) != None ]] || break
  done
  py -c 'import json,os,sys
def load(p):
    return json.load(open(p)) if os.path.exists(p) else None
d={"before": load(sys.argv[1]), "after": load(sys.argv[2]), "waited_s": float(sys.argv[3]),
   "attempts": int(sys.argv[4]), "recalibrated": sys.argv[6] == "1"}
d={k: v for k, v in d.items() if v is not None}
open(sys.argv[5], "w").write(json.dumps(d, indent=2) + "\n")' \
    "$st.before.json" "$st.after.json" "$waited" "$attempts" "$st.json" "$recal"
  rm -f "$st.before.json" "$st.after.json"
  state_text=$(py -c 'import json,sys; d=json.load(open(sys.argv[1]))
f=lambda k: "%.2fx" % d[k]["ratio"] if k in d else "?"
m=(d.get("before") or {}).get("model")
w=("; waited %d s" % d["waited_s"] if d["waited_s"] >= 5 else "")
w+=("; calibrated again" if d.get("recalibrated") else "") + ("; run twice" if d["attempts"] > 1 else "")
r=[p["reverse"]["ratio"] for p in (d.get("before"), d.get("after"))
   if p and p.get("alike") is False and "reverse" in p]
w+=("; the CPUs not slowed alike: the other way %s" % "/".join("%.2fx" % x for x in r) if r else "")
sp=[(d.get(k) or {}).get("speed_offset_pct") for k in ("before", "after")]
w+=("; speed %s" % "/".join("?" if x is None else "%+.0f %%" % x for x in sp)
    if any(x is not None for x in sp) else "")
print(" (state %s/%s, model %s%s)" % (f("before"), f("after"), "%.2fx" % m["ratio"] if m else "none", w))' "$st.json")
}

rm -rf "$out/sim-band" "$out/state"
mkdir -p "$out"/{hw,sim,compare,logs,scenarios}
((state_check)) && mkdir -p "$out/state"
start=$(date +%s)
load_start=$(cut -d' ' -f1 /proc/loadavg)
ok=() runs_ok=() failed=() band_failed=() skipped=()
band_runs=0 band_tenths=0
i=0
for file in "${scenarios[@]}"; do
  i=$((i + 1))
  name=$(basename "$file" .json)
  source_file=$file
  # Its platform, and the CPUs it needs: its highest core + 1.
  read -r given_platform needs < <(py -c 'import json,sys; d=json.load(open(sys.argv[1]))
n=d["nodes"]; cores=[n["controller"]["core"]]+[x["core"] for x in n.get("rt",[])+n.get("nrt",[])]
print(d.get("platform"), max(cores)+1)' "$file")
  if ((needs > cpus)); then
    printf '[%d/%d] %-26s skipped: needs %d CPUs (cores 0-%d), this host has %d\n' "$i" \
      "${#scenarios[@]}" "$name" "$needs" $((needs - 1)) "$cpus"
    skipped+=("$name=needs $needs CPUs (cores 0-$((needs - 1))), this host has $cpus")
    continue
  fi
  # The suite's files name `host`; another platform (ROSGUARD_VALIDATE_PLATFORM) runs a copy.
  if [[ $given_platform != "$platform" ]]; then
    with_platform "$file" "$platform" "$out/scenarios/$name.json"
    file=$out/scenarios/$name.json
  fi
  printf '[%d/%d] %-26s' "$i" "${#scenarios[@]}" "$name"
  status=ok
  for backend in hw sim; do
    t0=$(date +%s%N)
    log=$out/logs/$name-$backend.log
    rc=0
    state_text=
    if [[ $backend == hw ]] && ((state_check)); then
      hw_in_state "$name" "$file" "$log"
    else
      "$rosguard" run "$file" --backend "$backend" --out "$out/$backend/$name" --overwrite \
        > "$log" 2>&1 || rc=$?
    fi
    if ((rc == 130 || rc == 143)); then
      echo " $backend interrupted; stopping (the folders hold the complete rows)" >&2
      exit "$rc"
    fi
    if ((rc != 0)); then
      echo " $backend FAILED (exit $rc; see $log)"
      tail -n 5 "$log" | sed 's/^/    /'
      failed+=("$name=the $backend run failed; see $log")
      status=failed
      break
    fi
    tenths=$((($(date +%s%N) - t0) / 100000000))
    printf ' %s %3d.%d s%s' "$backend" $((tenths / 10)) $((tenths % 10)) "$state_text"
  done
  [[ $status == ok ]] || continue
  # The band: the same scenario in sim on each band platform of the host model.
  if ((${#band_files[@]})); then
    t0=$(date +%s%N)
    ran=0
    for band_file in "${band_files[@]}"; do
      variant=$(basename "$band_file" .json)
      copy=$out/scenarios/$name@$variant.json
      with_platform "$source_file" "$band_file" "$copy"
      log=$out/logs/$name-band-$variant.log
      rc=0
      "$rosguard" run "$copy" --backend sim --out "$out/sim-band/$variant/$name" --overwrite \
        > "$log" 2>&1 || rc=$?
      if ((rc == 130 || rc == 143)); then
        echo " band run on $variant interrupted; stopping" >&2
        exit "$rc"
      fi
      if ((rc != 0)); then
        # Left out of compare and the report alike (the report names the missing run).
        band_failed+=("$name on $variant (exit $rc; see $log)")
        rm -rf "$out/sim-band/$variant/$name"
      else
        ran=$((ran + 1))
      fi
    done
    tenths=$((($(date +%s%N) - t0) / 100000000))
    band_runs=$((band_runs + ran))
    band_tenths=$((band_tenths + tenths))
    printf ' band %d run(s) %d.%d s' "$ran" $((tenths / 10)) $((tenths % 10))
    ((ran == ${#band_files[@]})) || printf ' (%d FAILED)' $((${#band_files[@]} - ran))
  fi
  runs_ok+=("$name")
  if ((analysis)); then
    compare_one "$name"
  else
    echo
  fi
done

load_end=$(cut -d' ' -f1 /proc/loadavg)
if ((${#skipped[@]})); then
  echo "validate: ${#skipped[@]} scenario(s) skipped (more CPUs than this host's $cpus):" \
       "${skipped[*]%%=*}"
fi
echo "validate: suite run in $(($(date +%s) - start)) s (load average $load_start at the" \
     "start, $load_end at the end, on $cpus CPUs)"
if ((${#recalibrated[@]})); then
  echo "validate: calibrated again before ${recalibrated[*]}: the host stayed in another" \
       "DRAM-interference state than the model's; each scenario is compared with the model" \
       "installed when it ran (logs: $out/logs/recalibrate-before-*.log)"
fi
if ((${#band_files[@]})); then
  echo "validate: prediction band: $band_runs band run(s) on ${#band_files[@]} platform(s) in" \
       "$((band_tenths / 10)).$((band_tenths % 10)) s"
  for f in "${band_failed[@]}"; do
    echo "validate: warning: a band run failed: $f; the band is made from the others" >&2
  done
fi
# The machine's CPU as lscpu names it, beside the date in the report and the README block.
cpu=$(LC_ALL=C lscpu 2>/dev/null | sed -n 's/^Model name: *//p' | head -n 1 || true)
# What --report needs to compare and report later.
declare -p runs_ok failed skipped cpu cpus load_start load_end band_runs band_compare \
  recalibrated > "$out/suite.state"
if ((!analysis)); then
  echo "validate: python3 here lacks numpy, pandas, matplotlib or scipy (the analysis): the runs" \
       "are in $out/{hw,sim}/; copy $out to a machine with them and run" \
       "tools/validate.sh --report there (ROSGUARD_VALIDATE_OUT=<the copy>) for compare and the" \
       "report"
  if ((${#failed[@]})); then
    echo "validate: ${#failed[@]} scenario(s) failed: ${failed[*]%%=*}" >&2
    exit 1
  fi
  exit 0
fi
write_report

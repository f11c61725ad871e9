#!/usr/bin/env bash
# rosguard run --slurm and rosguard status without a cluster: stand-ins for sbatch and squeue on
# PATH record what rosguard asks and answer as Slurm would; the array tasks are run here, by
# hand, with the SLURM_* variables a task gets. (tests/slurm/real_slurm_test.sh runs a cluster.)
# Usage: cli_test.sh ROSGUARD_FAKE CASE   (from the source root; the fake backend's fixture)
set -u
bin=$1
case=$2
# Not a Slurm job ourselves (ctest may run in one): shard entries name no Slurm task.
unset SLURM_JOB_ID SLURM_ARRAY_JOB_ID SLURM_ARRAY_TASK_ID
scenario=tests/app/fixtures/sweep.json # 12 points x 2 repetitions
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() {
  echo "FAIL: $*"
  exit 1
}
rows() { tail -n +2 "$1/points.csv" | wc -l; }
dups() { tail -n +2 "$1/points.csv" | cut -d, -f1,2 | sort | uniq -d | wc -l; }
expect_exit() { # CODE MESSAGE-REGEX COMMAND...: exit code and a line of stderr
  local code=$1 re=$2
  shift 2
  "$@" >"$tmp/out" 2>"$tmp/err"
  local got=$?
  [[ $got -eq $code ]] || fail "'$*' exited $got, not $code: $(cat "$tmp/err")"
  grep -qE -- "$re" "$tmp/err" || fail "'$*': stderr lacks /$re/: $(cat "$tmp/err")"
}

# sbatch and squeue stand-ins: sbatch logs its arguments and answers "42;testcluster" (or fails
# with FAKE_SBATCH_EXIT); squeue prints $tmp/squeue.txt (or fails without it).
mkdir -p "$tmp/bin"
cat >"$tmp/bin/sbatch" <<EOF
#!/bin/bash
printf '%s\n' "\$@" >"$tmp/sbatch.args"
if [[ -n \${FAKE_SBATCH_EXIT:-} ]]; then
  echo "sbatch: error: Batch job submission failed: Invalid partition name specified" >&2
  exit \$FAKE_SBATCH_EXIT
fi
echo "42;testcluster"
EOF
cat >"$tmp/bin/squeue" <<EOF
#!/bin/bash
printf '%s\n' "\$@" >"$tmp/squeue.args"
[[ -f $tmp/squeue.txt ]] || { echo "squeue: error: Unable to contact slurm controller" >&2; exit 1; }
cat "$tmp/squeue.txt"
EOF
chmod +x "$tmp/bin/sbatch" "$tmp/bin/squeue"
withslurm=(env "PATH=$tmp/bin:$PATH")
noslurm=(env "PATH=$tmp/empty")

case $case in
dry-run)
  # The script on stdout, absolute paths, one shard per task, nothing written or submitted.
  "${withslurm[@]}" "$bin" run $scenario --slurm --dry-run --out "$tmp/d" --array 3 \
    --sbatch-arg=--partition=short --sbatch-arg=--time=10 >"$tmp/script" 2>"$tmp/err" ||
    fail "dry run exited $?: $(cat "$tmp/err")"
  [[ ! -e $tmp/d && ! -e $tmp/sbatch.args ]] || fail "a dry run wrote or submitted something"
  exe=$(readlink -f "$bin")
  for line in '#!/bin/bash' '#SBATCH --array=0-2' "#SBATCH --output=$tmp/d/slurm/%A_%a.out" \
    '#SBATCH --partition=short' '#SBATCH --time=10' '#SBATCH --job-name=rosguard-runner-test' \
    "exec $exe run $PWD/$scenario --out $tmp/d --shard \"\$SLURM_ARRAY_TASK_ID/3\" --resume --jobs \"\${SLURM_CPUS_PER_TASK:-1}\""; do
    grep -qxF -- "$line" "$tmp/script" || fail "the script lacks the line: $line"
  done
  # rosguard's #SBATCH lines come first: the user's can override them.
  [[ $(grep -n -- '--partition=short' "$tmp/script" | cut -d: -f1) -gt \
    $(grep -n -- '--array=0-2' "$tmp/script" | cut -d: -f1) ]] || fail "sbatch args before the array"
  bash -n "$tmp/script" || fail "the script is not valid bash"
  # Default: one shard per point (12 here); --jobs, --backend and --trace reach the tasks.
  "${noslurm[@]}" "$bin" run $scenario --slurm --dry-run --out "$tmp/d" --jobs 3 --trace \
    >"$tmp/script" 2>/dev/null || fail "dry run without sbatch exited $?"
  grep -qxF '#SBATCH --array=0-11' "$tmp/script" || fail "default array is not one task per point"
  grep -qE -- '--shard "\$SLURM_ARRAY_TASK_ID/12" --resume --jobs 3 --trace$' "$tmp/script" ||
    fail "--jobs / --trace not passed on: $(tail -n 1 "$tmp/script")"
  ;;
errors)
  # Bad values: exit 2 and nothing written; no sbatch: exit 1.
  expect_exit 2 'Value 0 not in range' "${withslurm[@]}" "$bin" run $scenario --slurm --array 0 --out "$tmp/e"
  expect_exit 2 '--array 13 exceeds the 12 points' "${withslurm[@]}" "$bin" run $scenario --slurm --array 13 --out "$tmp/e"
  expect_exit 2 '--array goes with --slurm' "$bin" run $scenario --array 2 --out "$tmp/e"
  expect_exit 2 '--dry-run goes with --slurm' "$bin" run $scenario --dry-run --out "$tmp/e"
  expect_exit 2 '--sbatch-arg goes with --slurm' "$bin" run $scenario --sbatch-arg=--time=5 --out "$tmp/e"
  expect_exit 2 '--shard and --slurm contradict' "${withslurm[@]}" "$bin" run $scenario --slurm --shard 0/2 --out "$tmp/e"
  expect_exit 2 "takes one sbatch option" "${withslurm[@]}" "$bin" run $scenario --slurm --sbatch-arg=short --out "$tmp/e"
  expect_exit 2 "cannot be written into an #SBATCH line" "${withslurm[@]}" "$bin" run $scenario --slurm "--sbatch-arg=--comment=a b" --out "$tmp/e"
  expect_exit 2 "rosguard sets the array itself" "${withslurm[@]}" "$bin" run $scenario --slurm --sbatch-arg=--array=0-3 --out "$tmp/e"
  expect_exit 2 "choose a results folder" "${withslurm[@]}" "$bin" run $scenario --slurm --out "$tmp/e f"
  expect_exit 2 "choose a results folder" "${withslurm[@]}" "$bin" run $scenario --slurm --out "$tmp/e%j"
  expect_exit 2 "no such file|does not exist|cannot" "${withslurm[@]}" "$bin" run tests/slurm/none.json --slurm --out "$tmp/e"
  [[ ! -e $tmp/e && ! -e $tmp/sbatch.args ]] || fail "a refused submission wrote or submitted something"
  expect_exit 1 'sbatch is not on PATH' "${noslurm[@]}" "$bin" run $scenario --slurm --out "$tmp/e"
  [[ ! -e $tmp/e ]] || fail "a submission without sbatch wrote $tmp/e"
  FAKE_SBATCH_EXIT=1 expect_exit 1 'sbatch refused the job \(exit 1' "${withslurm[@]}" "$bin" run $scenario --slurm --out "$tmp/e"
  grep -q 'Invalid partition name' "$tmp/err" || fail "sbatch's own message is not shown"
  ;;
submit)
  # Submission: sbatch --parsable on the script, the job id printed, job.json written; then the
  # tasks, run here side by side as Slurm would, fill the folder as a local run does.
  "${withslurm[@]}" "$bin" run $scenario --slurm --array 3 --out "$tmp/s" >"$tmp/out" 2>"$tmp/err" ||
    fail "submission exited $?: $(cat "$tmp/err")"
  cat "$tmp/out"
  grep -q '^rosguard: submitted Slurm job 42: 3 array tasks' "$tmp/out" || fail "no job id printed"
  grep -qF "rosguard status $tmp/s" "$tmp/out" || fail "does not say how to follow the job"
  [[ $(cat "$tmp/sbatch.args") == "--parsable"$'\n'"$tmp/s/slurm/run.sbatch" ]] ||
    fail "sbatch was called with: $(cat "$tmp/sbatch.args")"
  [[ -x $tmp/s/slurm/run.sbatch ]] || fail "the script is not executable"
  /usr/bin/python3 - "$tmp/s/slurm/job.json" <<'PY' || fail "job.json"
import json, sys
j = json.load(open(sys.argv[1]))
assert j["job_id"] == "42" and j["cluster"] == "testcluster", j
assert j["shards"] == 3 and j["points"] == 12 and j["repetitions"] == 2, j
PY
  # --quiet: the job id alone. A folder that holds the job's script but no run yet may be
  # submitted again.
  [[ $("${withslurm[@]}" "$bin" run $scenario --slurm --array 3 --out "$tmp/s" --quiet) == 42 ]] ||
    fail "--quiet does not print the job id alone"
  # Outside an array task the script refuses to run.
  bash "$tmp/s/slurm/run.sbatch" >/dev/null 2>&1
  [[ $? -eq 2 ]] || fail "the script ran outside an array task"
  pids=()
  for i in 0 1 2; do
    SLURM_ARRAY_JOB_ID=42 SLURM_ARRAY_TASK_ID=$i SLURM_JOB_ID=$((50 + i)) ROSGUARD_FAKE_SLEEP_MS=20 \
      bash "$tmp/s/slurm/run.sbatch" >"$tmp/task$i.log" 2>&1 &
    pids+=($!)
  done
  for p in "${pids[@]}"; do
    wait "$p" || fail "a task exited $?"
  done
  "$bin" run $scenario --out "$tmp/local" --quiet || fail "local run"
  cmp "$tmp/local/points.csv" "$tmp/s/points.csv" || fail "points.csv differs from a local run"
  cmp "$tmp/local/samples.csv" "$tmp/s/samples.csv" || fail "samples.csv differs from a local run"
  /usr/bin/python3 - "$tmp/s/manifest.json" <<'PY' || fail "manifest shard entries"
import json, sys
m = json.load(open(sys.argv[1]))
assert m["status"] == "complete", m["status"]
for i in range(3):
    e = m["shards"]["%d/3" % i]
    assert e["status"] == "complete" and e["slurm_job"] == "42_%d" % i, e
    assert e["pid"] > 0 and e["host"], e
PY
  # The folder now holds a run: submitting again needs --resume (or --overwrite).
  expect_exit 2 'already holds a run' "${withslurm[@]}" "$bin" run $scenario --slurm --out "$tmp/s"
  "${withslurm[@]}" "$bin" run $scenario --slurm --out "$tmp/s" --resume --quiet >/dev/null ||
    fail "--resume submission"
  "${withslurm[@]}" "$bin" run $scenario --slurm --out "$tmp/s" --overwrite --quiet >/dev/null ||
    fail "--overwrite submission"
  [[ ! -e $tmp/s/points.csv && ! -e $tmp/s/manifest.json ]] || fail "--overwrite kept the old run"
  ;;
status)
  # Not a results folder: exit 2.
  expect_exit 2 'is not a results folder' "$bin" status "$tmp"
  expect_exit 2 'does not exist' "$bin" status "$tmp/none"
  mkdir -p "$tmp/bad" && echo '[1' >"$tmp/bad/manifest.json"
  expect_exit 2 'not a file rosguard writes' "$bin" status "$tmp/bad"
  # A shard killed mid-way (SIGKILL: its entry still says running) shows as stopped, the other
  # as not started; the printed commands finish the folder without a duplicate row.
  ROSGUARD_FAKE_SLEEP_MS=150 setsid "$bin" run $scenario --out "$tmp/k" --shard 1/2 --jobs 1 --quiet &
  pid=$!
  for _ in $(seq 300); do
    [[ -f $tmp/k/points.csv && $(rows "$tmp/k") -ge 2 ]] && break
    sleep 0.1
  done
  "$bin" status "$tmp/k" >"$tmp/out" || fail "status of a running shard exited $?"
  grep -qE "^  1/2 .* running \(pid $pid\)$" "$tmp/out" || fail "a running shard: $(cat "$tmp/out")"
  kill -KILL $pid
  wait $pid 2>/dev/null
  "$bin" status "$tmp/k" >"$tmp/out" || fail "status exited $?"
  cat "$tmp/out"
  grep -qE "^  1/2 +[0-9]+/6 +[1-9][0-9]*/12 +stopped: its process \(pid $pid\) is gone" "$tmp/out" ||
    fail "the killed shard is not shown as stopped"
  grep -qE '^  0/2 +0/6 +0/12 +not started$' "$tmp/out" || fail "the other shard is not 'not started'"
  grep -qE '^  all .* incomplete$' "$tmp/out" || fail "the folder is not incomplete"
  grep -q '^Re-run' "$tmp/out" || fail "no re-run commands"
  # --json: the same shards, states and re-run commands.
  "$bin" status "$tmp/k" --json >"$tmp/out.json" || fail "status --json exited $?"
  /usr/bin/python3 - "$tmp/out.json" "$tmp/out" <<'PY' || fail "status --json: $(cat "$tmp/out.json")"
import json, sys
j, text = json.load(open(sys.argv[1])), open(sys.argv[2]).read()
assert j["kind"] == "run" and j["state"] == "incomplete" and j["runs_total"] == 24, j
shards = {s["shard"]: s for s in j["shards"]}
assert set(shards) == {"0/2", "1/2"}, shards
assert shards["0/2"]["state"] == "not started" and shards["0/2"]["runs_done"] == 0
assert shards["1/2"]["state"].startswith("stopped: its process") and not shards["1/2"]["live"]
assert j["runs_done"] == shards["1/2"]["runs_done"] > 0
assert [r["shard"] for r in j["rerun"]] == ["0/2", "1/2"], j["rerun"]
assert all("  here:     " + r["command"] in text for r in j["rerun"]), (j["rerun"], text)
PY
  grep -oE 'rosguard run .* --resume$' "$tmp/out" | sed "s|^rosguard |$bin |" >"$tmp/rerun"
  [[ $(wc -l <"$tmp/rerun") -eq 2 ]] || fail "expected two re-run commands: $(cat "$tmp/rerun")"
  bash "$tmp/rerun" >/dev/null 2>&1 || fail "the printed commands failed"
  "$bin" status "$tmp/k" >"$tmp/out" || fail "status exited $?"
  grep -qE '^  all +12/12 +24/24 +complete$' "$tmp/out" || fail "not complete: $(cat "$tmp/out")"
  grep -q '^Re-run' "$tmp/out" && fail "a complete folder still lists re-runs"
  "$bin" status "$tmp/k" --json >"$tmp/out.json" || fail "status --json exited $?"
  /usr/bin/python3 -c 'import json, sys; j = json.load(open(sys.argv[1]))
assert j["state"] == "complete" and j["rerun"] == [] and j["runs_done"] == 24, j' "$tmp/out.json" ||
    fail "status --json of a complete folder: $(cat "$tmp/out.json")"
  [[ $(dups "$tmp/k") -eq 0 ]] || fail "duplicate rows after the re-run"
  "$bin" run $scenario --out "$tmp/local" --quiet || fail "local run"
  cmp "$tmp/local/points.csv" "$tmp/k/points.csv" || fail "points.csv differs from a local run"
  # A failed shard: its error, and the command to re-run it.
  ROSGUARD_FAKE_FAIL_AT=15 "$bin" run $scenario --out "$tmp/f" --jobs 1 --quiet 2>/dev/null
  "$bin" status "$tmp/f" >"$tmp/out" || fail "status exited $?"
  grep -qE '^  0/1 .* failed: point .*fake failure at threshold 15$' "$tmp/out" ||
    fail "the failed shard: $(cat "$tmp/out")"
  grep -qF "rosguard run $scenario --backend sim --out $tmp/f --shard 0/1 --resume" "$tmp/out" ||
    fail "no re-run command for the failed shard"
  # Run on another backend than the scenario's (--backend hw): the re-run command keeps it, and
  # finishes the run.
  ROSGUARD_FAKE_FAIL_AT=15 "$bin" run $scenario --backend hw --out "$tmp/h" --jobs 1 --quiet 2>/dev/null
  "$bin" status "$tmp/h" >"$tmp/out" || fail "status exited $?"
  grep -qF "rosguard run $scenario --backend hw --out $tmp/h --shard 0/1 --resume" "$tmp/out" ||
    fail "the re-run command of an hw run does not keep --backend hw: $(cat "$tmp/out")"
  grep -oE 'rosguard run .* --resume$' "$tmp/out" | sed "s|^rosguard |$bin |" >"$tmp/rerun"
  bash "$tmp/rerun" >/dev/null 2>&1 || fail "the printed re-run command failed"
  grep -q '"backend": "hw"' "$tmp/h/manifest.json" || fail "the re-run changed the backend"
  [[ $(dups "$tmp/h") -eq 0 ]] || fail "duplicate rows after the re-run"
  ;;
status-slurm)
  # Shards of a submitted job that have not started: Slurm's queue says pending, starting, or
  # ended without rosguard ever running (e.g. a node could not start it).
  "${withslurm[@]}" "$bin" run $scenario --slurm --array 4 --out "$tmp/q" --quiet >/dev/null ||
    fail "submission"
  script=$tmp/q/slurm/run.sbatch
  printf '%s\n' "42_0|PENDING|Resources|$script" "42_1|RUNNING|None|$script" \
    "42_2|FAILED|JobLaunchFailure|$script" "41_3|PENDING|None|/elsewhere/run.sbatch" \
    "43|RUNNING|None|$script" >"$tmp/squeue.txt"
  "${withslurm[@]}" "$bin" status "$tmp/q" >"$tmp/out" || fail "status exited $?"
  cat "$tmp/out"
  grep -qE '^  0/4 +0/3 +0/6 +pending \(Slurm 42_0\)$' "$tmp/out" || fail "pending task"
  grep -qE '^  1/4 .* starting \(Slurm 42_1\)$' "$tmp/out" || fail "running task without entry"
  grep -qE '^  2/4 .* not started: Slurm 42_2 ended FAILED$' "$tmp/out" || fail "failed task"
  grep -qE '^  3/4 .* not started$' "$tmp/out" || fail "a task of another script was taken"
  grep -qE '^  all +0/12 +0/24 +running$' "$tmp/out" || fail "overall"
  grep -qxF "  on Slurm: sbatch --array=2,3 $script" "$tmp/out" || fail "re-run command"
  grep -qx -- '-r' "$tmp/squeue.args" || fail "squeue not asked for one line per array task"
  # squeue fails: said so; the states come from the manifest alone.
  rm "$tmp/squeue.txt"
  "${withslurm[@]}" "$bin" status "$tmp/q" >"$tmp/out" || fail "status exited $?"
  grep -q "^note: Slurm's queue could not be read: squeue failed: .*Unable to contact" "$tmp/out" ||
    fail "squeue's failure is not reported: $(cat "$tmp/out")"
  ;;
*)
  fail "unknown case $case"
  ;;
esac
echo "PASS: $case"

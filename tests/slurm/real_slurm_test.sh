#!/usr/bin/env bash
# rosguard run --slurm against a real Slurm: a one-node cluster on localhost (cluster.sh) runs
#  A. a sim sweep as a 4-task array; the merged points.csv and samples.csv are byte-identical to
#     a local run, and rosguard status reports every shard complete;
#  B. the fake backend's sweep as a 4-task array in which two shards fail (a point throws) and
#     one is killed (SIGKILL) mid-way: rosguard status names them (failed / stopped) and prints
#     the sbatch command that re-runs them; run as printed, they finish the folder without a
#     duplicate row, byte-identical to a local run.
# SKIPPED with the reason where a cluster cannot run here (not root, packages missing, daemons
# not up in time).
# Usage: real_slurm_test.sh ROSGUARD ROSGUARD_FAKE SOURCE_DIR
set -u
rosguard=$1
fake=$2
src=$3
here=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=tests/slurm/cluster.sh
source "$here/cluster.sh"

fail() {
  echo "FAIL: $*"
  exit 1
}
rows() { tail -n +2 "$1/points.csv" | wc -l; }
dups() { tail -n +2 "$1/points.csv" | cut -d, -f1,2 | sort | uniq -d | wc -l; }
shard_field() { # DIR SHARD FIELD: a field of the manifest's entry for a shard
  /usr/bin/python3 -c '
import json, sys
e = json.load(open(sys.argv[1] + "/manifest.json"))["shards"].get(sys.argv[2], {})
print(e.get(sys.argv[3], ""))' "$1" "$2" "$3" 2>/dev/null
}

slurm_cluster_start
work=$slurm_cluster_dir/work
mkdir -p "$work"
cpus=$(($(nproc) >= 2 ? 2 : 1))

echo "== A. sim sweep as a 4-task array (--cpus-per-task=$cpus)"
scenario=$src/scenarios/bench/sweep-100.json
t0=$SECONDS
job=$("$rosguard" run "$scenario" --slurm --array 4 --out "$work/a" --quiet \
  --sbatch-arg=--cpus-per-task=$cpus) || fail "rosguard run --slurm exited $?"
[[ $job =~ ^[0-9]+$ ]] || fail "--slurm --quiet printed '$job', not a job id"
echo "submitted job $job"
"$rosguard" status "$work/a" || fail "status while the job runs exited $?"
slurm_wait_job "$job" 300 || fail "the array job did not finish"
echo "job $job done in $((SECONDS - t0)) s"
status=$("$rosguard" status "$work/a") || fail "status exited $?"
echo "$status"
[[ $(grep -cE '^  [0-3]/4 .* complete$' <<<"$status") -eq 4 ]] || fail "not every shard is complete"
grep -qE '^  all +100/100 +100/100 +complete$' <<<"$status" || fail "status does not say 100/100 complete"
for i in 0 1 2 3; do
  [[ $(shard_field "$work/a" $i/4 slurm_job) == "${job}_$i" ]] ||
    fail "shard $i/4 does not record Slurm task ${job}_$i"
  [[ $(shard_field "$work/a" $i/4 command) == *"--shard $i/4 --resume --jobs $cpus"* ]] ||
    fail "shard $i/4 did not run with --jobs $cpus (--cpus-per-task): $(shard_field "$work/a" $i/4 command)"
  [[ -s $work/a/slurm/${job}_$i.out ]] || fail "no log $work/a/slurm/${job}_$i.out"
done
[[ ! -e $work/a/.lock ]] || fail "the shards left a .lock behind"
"$rosguard" run "$scenario" --out "$work/local" --quiet || fail "local run exited $?"
cmp "$work/local/points.csv" "$work/a/points.csv" || fail "points.csv differs from the local run"
cmp "$work/local/samples.csv" "$work/a/samples.csv" || fail "samples.csv differs from the local run"
echo "points.csv ($(rows "$work/a") rows) and samples.csv byte-identical to a local run"

echo "== B. failed and killed shards, re-run as rosguard status says"
fixture=$src/tests/app/fixtures/sweep.json
# Points at threshold 15 throw (two shards fail after their first rows); every task sleeps
# 1 s, so that shard 3/4 is caught while it runs.
job=$(ROSGUARD_FAKE_FAIL_AT=15 ROSGUARD_FAKE_SLEEP_MS=1000 "$fake" run "$fixture" --slurm \
  --array 4 --out "$work/b" --quiet) || fail "rosguard_fake run --slurm exited $?"
pid=""
for _ in $(seq 1200); do
  [[ $(shard_field "$work/b" 3/4 status) == running ]] && pid=$(shard_field "$work/b" 3/4 pid)
  [[ -n $pid ]] && break
  sleep 0.1
done
[[ -n $pid ]] || fail "shard 3/4 never showed up running in the manifest"
sleep 1.5 # let it write a row or two
kill -KILL "$pid" || fail "shard 3/4 (pid $pid) finished before it could be killed: raise the sleep"
echo "killed shard 3/4 (pid $pid, Slurm ${job}_3)"
slurm_wait_job "$job" 300 || fail "the array job did not finish"
status=$("$fake" status "$work/b") || fail "status exited $?"
echo "$status"
failed=$(grep -cE '^  [0-3]/4 .* failed: .*fake failure at threshold 15' <<<"$status")
((failed >= 1)) || fail "status shows no failed shard"
grep -qE "^  3/4 .* stopped: Slurm ${job}_3 ended [A-Z_]+.* without finishing" <<<"$status" ||
  fail "status does not show the killed shard 3/4 as stopped"
grep -qE '^  all .* incomplete$' <<<"$status" || fail "status does not say incomplete"
rerun=$(grep -oE 'sbatch --array=[0-9,]+ .*run\.sbatch' <<<"$status") ||
  fail "status prints no sbatch command to re-run the shards"
[[ $(wc -l <<<"$rerun") -eq 1 ]] || fail "more than one sbatch command: $rerun"
echo "shards: $failed failed, 3/4 stopped; $(rows "$work/b") rows kept; re-run: $rerun"
[[ $(dups "$work/b") -eq 0 ]] || fail "duplicate rows before the re-run"
# As printed, without the failure: sbatch takes this environment (--export=ALL).
job2=$(eval "${rerun/sbatch/sbatch --parsable}") || fail "the re-run command failed: $rerun"
job2=${job2%%;*}
slurm_wait_job "$job2" 300 || fail "the re-run job did not finish"
status=$("$fake" status "$work/b") || fail "status exited $?"
echo "$status"
grep -qE '^  all +12/12 +24/24 +complete$' <<<"$status" || fail "the re-run did not complete the folder"
[[ $(dups "$work/b") -eq 0 ]] || fail "the re-run duplicated rows"
"$fake" run "$fixture" --out "$work/blocal" --quiet || fail "local fake run exited $?"
cmp "$work/blocal/points.csv" "$work/b/points.csv" || fail "points.csv differs from a local run after the re-run"
cmp "$work/blocal/samples.csv" "$work/b/samples.csv" || fail "samples.csv differs from a local run after the re-run"
echo "re-run job $job2 finished the folder: 24 rows, none twice, byte-identical to a local run"
echo "PASS"

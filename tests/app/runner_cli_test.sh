#!/usr/bin/env bash
# Runner mechanics through the real CLI (tools/rosguard/commands/) with the fake backend (app/fake/):
# determinism over --jobs and shards, crash safety, SIGINT, resume, failures, folders, list,
# adjacent baselines, check --json and the loader's warnings in run.
# Usage: runner_cli_test.sh ROSGUARD_FAKE CASE   (from the source root)
set -u
bin=$1
case=$2
scenario=tests/app/fixtures/sweep.json
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
rows() { tail -n +2 "$1/points.csv" | wc -l; }
# Every row of points.csv has exactly as many fields as the header (no torn rows).
complete_rows() {
  awk -F, 'NR==1 {n=NF; next} NF!=n {bad=1} END {exit bad}' "$1/points.csv" ||
    fail "$1/points.csv has a row with a wrong field count"
}
# Waits (up to 30 s) until a running run has written at least $2 rows.
wait_rows() {
  for _ in $(seq 300); do
    [[ -f "$1/points.csv" && $(rows "$1") -ge $2 ]] && return 0
    sleep 0.1
  done
  fail "no $2 rows in $1 after 30 s"
}
status() { /usr/bin/python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['status'])" "$1/manifest.json"; }

case $case in
determinism)
  # Byte-identical results whatever --jobs and sharding were.
  "$bin" run $scenario --out "$tmp/j1" --jobs 1 --quiet || fail "jobs 1"
  "$bin" run $scenario --out "$tmp/j2" --jobs 2 --quiet || fail "jobs 2"
  # 9 workers: several task hosts (kWorkersPerHost 4, at most one per CPU), tasks spread over them.
  "$bin" run $scenario --out "$tmp/j9" --jobs 9 --quiet || fail "jobs 9"
  "$bin" run $scenario --out "$tmp/sh" --shard 1/2 --quiet || fail "shard 1/2"
  [[ $(status "$tmp/sh") == partial ]] || fail "one shard of two: status $(status "$tmp/sh")"
  "$bin" run $scenario --out "$tmp/sh" --shard 0/2 --quiet || fail "shard 0/2"
  [[ $(status "$tmp/sh") == complete ]] || fail "both shards: status $(status "$tmp/sh")"
  [[ $(rows "$tmp/j1") -eq 24 ]] || fail "expected 24 rows, got $(rows "$tmp/j1")"
  for d in j2 j9 sh; do
    cmp "$tmp/j1/points.csv" "$tmp/$d/points.csv" || fail "points.csv differs for $d"
    cmp "$tmp/j1/samples.csv" "$tmp/$d/samples.csv" || fail "samples.csv differs for $d"
  done
  ;;
concurrent)
  # Shards started at the same time into one folder lose nothing: every run's row and samples
  # exactly once, the manifest complete, the files byte-identical to a single-process run.
  "$bin" run $scenario --out "$tmp/ref" --quiet || fail "reference run"
  pids=()
  for i in 0 1 2; do
    ROSGUARD_FAKE_SLEEP_MS=30 "$bin" run $scenario --out "$tmp/c" --shard $i/3 --jobs 1 --quiet &
    pids+=($!)
    sleep 0.07
  done
  for pid in "${pids[@]}"; do
    wait "$pid" || fail "a shard exited $?"
  done
  echo "rows $(rows "$tmp/c") of 24, samples $(tail -n +2 "$tmp/c/samples.csv" | wc -l) of 240"
  [[ ! -e "$tmp/c/.lock" ]] || fail "the shards left a .lock behind"
  dups=$(tail -n +2 "$tmp/c/points.csv" | cut -d, -f1,2 | sort | uniq -d | wc -l)
  [[ $dups -eq 0 ]] || fail "$dups run(s) have more than one row"
  [[ $(rows "$tmp/c") -eq 24 ]] || fail "expected 24 rows, got $(rows "$tmp/c")"
  tail -n +2 "$tmp/c/samples.csv" | cut -d, -f1,2 | sort | uniq -c | awk '$1 != 10 {bad=1} END {exit bad}' ||
    fail "a run does not have exactly its 10 samples"
  cmp "$tmp/ref/points.csv" "$tmp/c/points.csv" || fail "points.csv differs from a single run"
  cmp "$tmp/ref/samples.csv" "$tmp/c/samples.csv" || fail "samples.csv differs from a single run"
  /usr/bin/python3 - "$tmp/c/manifest.json" <<'PY' || fail "manifest does not describe the three shards"
import json, sys
m = json.load(open(sys.argv[1]))
assert m["status"] == "complete", m["status"]
assert m["counts"]["rows"] == 24, m["counts"]
assert sorted(m["shards"]) == ["0/3", "1/3", "2/3"], m["shards"]
assert all(s["status"] == "complete" for s in m["shards"].values()), m["shards"]
assert sum(s["rows_this_invocation"] for s in m["shards"].values()) == 24, m["shards"]
PY
  ;;
kill9)
  # A run killed with SIGKILL leaves only complete rows; --resume finishes it identically.
  "$bin" run $scenario --out "$tmp/ref" --quiet || fail "reference run"
  ROSGUARD_FAKE_SLEEP_MS=150 setsid "$bin" run $scenario --out "$tmp/k" --jobs 2 --quiet &
  pid=$!
  wait_rows "$tmp/k" 2
  kill -9 -- -$pid 2>/dev/null || kill -9 $pid
  wait $pid 2>/dev/null
  n=$(rows "$tmp/k")
  [[ $n -gt 0 && $n -lt 24 ]] || fail "expected a partial run, got $n rows"
  complete_rows "$tmp/k"
  [[ $(status "$tmp/k") == running ]] || fail "manifest of a killed run should say running"
  "$bin" run $scenario --out "$tmp/k" --resume 2> "$tmp/err" >/dev/null || fail "resume"
  grep -q "already in" "$tmp/err" || fail "resume did not report skipped runs"
  cmp "$tmp/ref/points.csv" "$tmp/k/points.csv" || fail "resumed points.csv differs"
  cmp "$tmp/ref/samples.csv" "$tmp/k/samples.csv" || fail "resumed samples.csv differs"
  [[ $(status "$tmp/k") == complete ]] || fail "manifest after resume should say complete"
  # samples.csv under another header (another rosguard's columns): --resume refuses, exit 2,
  # both files as they were (it kept the rows under the new header before).
  cp -r "$tmp/k" "$tmp/h"
  head -n 4 "$tmp/ref/points.csv" > "$tmp/h/points.csv"
  sed -i '1s/^/old_/' "$tmp/h/samples.csv"
  cp "$tmp/h/samples.csv" "$tmp/h/samples.before"
  "$bin" run $scenario --out "$tmp/h" --resume --quiet 2> "$tmp/err" >/dev/null
  rc=$?
  [[ $rc -eq 2 ]] || fail "resume over a foreign samples.csv exited $rc: $(cat "$tmp/err")"
  grep -q "samples.csv has other columns than this rosguard writes" "$tmp/err" ||
    fail "no error naming samples.csv: $(cat "$tmp/err")"
  cmp "$tmp/h/samples.csv" "$tmp/h/samples.before" || fail "samples.csv changed"
  [[ $(rows "$tmp/h") -eq 3 ]] || fail "points.csv changed: $(rows "$tmp/h") rows"
  ;;
containment)
  # Sim tasks run in workers forked by a task host (tools/rosguard/run/task_pool.h). A worker that
  # dies by a signal fails the run with that signal named; the runner killed alone (SIGKILL, not
  # its group) takes the host and its workers with it; a run that ends leaves no process behind.
  alive() { [[ -e /proc/$1 ]] && [[ $(awk '{print $3}' "/proc/$1/stat" 2>/dev/null) != Z ]]; }
  host_and_workers() {  # of runner $1: "HOST WORKER..." once the host has $2 workers
    for _ in $(seq 300); do
      local host
      host=$(pgrep -P "$1" | head -1)
      if [[ -n $host && $(pgrep -P "$host" | wc -l) -ge $2 ]]; then
        echo "$host" $(pgrep -P "$host")
        return 0
      fi
      sleep 0.1
    done
    fail "runner $1 has no task host with $2 workers after 30 s"
  }
  ROSGUARD_FAKE_SLEEP_MS=3000 "$bin" run $scenario --out "$tmp/seg" --jobs 2 --quiet 2>"$tmp/err" &
  pid=$!
  procs=($(host_and_workers $pid 2))
  kill -SEGV "${procs[1]}"
  wait $pid
  rc=$?
  [[ $rc -eq 1 ]] || fail "exit $rc after a worker died of SIGSEGV, expected 1"
  grep -q "worker process died with signal 11" "$tmp/err" || fail "no signal named: $(cat "$tmp/err")"
  for p in "${procs[@]}"; do alive "$p" && fail "process $p outlived the failed run"; done

  # Kills runner $1 with SIGKILL; fails with $2 unless the processes after it are gone in 5 s.
  kill_runner_expect_gone() {
    local runner=$1 why=$2
    shift 2
    kill -9 "$runner"
    wait "$runner" 2>/dev/null
    for _ in $(seq 50); do
      left=0
      for p in "$@"; do alive "$p" && left=1; done
      [[ $left -eq 0 ]] && return 0
      sleep 0.1
    done
    fail "$why"
  }
  ROSGUARD_FAKE_SLEEP_MS=3000 "$bin" run $scenario --out "$tmp/k" --jobs 2 --quiet &
  pid=$!
  procs=($(host_and_workers $pid 2))
  kill_runner_expect_gone $pid "the task host or a worker outlived the runner killed with SIGKILL" \
    "${procs[@]}"

  # With several task hosts (--jobs 9: three, at most one per CPU), all of them and their workers
  # die with the runner.
  expected_hosts=$(($(nproc) < 3 ? $(nproc) : 3))
  ROSGUARD_FAKE_SLEEP_MS=3000 "$bin" run $scenario --out "$tmp/k9" --jobs 9 --quiet &
  pid=$!
  for _ in $(seq 300); do
    hosts=($(pgrep -P $pid))
    workers=0
    for h in "${hosts[@]}"; do workers=$((workers + $(pgrep -P "$h" | wc -l))); done
    [[ ${#hosts[@]} -eq $expected_hosts && $workers -ge 9 ]] && break
    sleep 0.1
  done
  [[ ${#hosts[@]} -eq $expected_hosts ]] ||
    fail "--jobs 9: ${#hosts[@]} task host(s), expected $expected_hosts"
  [[ $workers -ge 9 ]] || fail "--jobs 9: $workers worker(s) running, expected 9"
  procs=("${hosts[@]}")
  for h in "${hosts[@]}"; do procs+=($(pgrep -P "$h")); done
  kill_runner_expect_gone $pid "a task host or a worker of --jobs 9 outlived the runner" \
    "${procs[@]}"

  "$bin" run $scenario --out "$tmp/ok" --jobs 2 --quiet &
  pid=$!
  host=$(pgrep -P $pid | head -1)
  wait $pid || fail "a plain run failed"
  [[ -z $host ]] || ! alive "$host" || fail "the task host outlived its run"
  [[ $(rows "$tmp/ok") -eq 24 ]] || fail "expected 24 rows, got $(rows "$tmp/ok")"
  ;;
sigint)
  # SIGINT stops an in-process (hw-like) run: exit 130, complete rows, status interrupted.
  for backend in hw sim; do
    out="$tmp/int-$backend"
    ROSGUARD_FAKE_SLEEP_MS=200 "$bin" run $scenario --backend $backend --out "$out" --quiet &
    pid=$!
    wait_rows "$out" 1
    kill -INT $pid
    wait $pid
    rc=$?
    [[ $rc -eq 130 ]] || fail "$backend: exit $rc after SIGINT, expected 130"
    complete_rows "$out"
    [[ $(status "$out") == interrupted ]] || fail "$backend: manifest status $(status "$out")"
    "$bin" run $scenario --backend $backend --out "$out" --resume --quiet || fail "$backend: resume"
    [[ $(rows "$out") -eq 24 ]] || fail "$backend: $(rows "$out") rows after resume"
  done
  ;;
resume_errors)
  # A value that was not measured (NaN, null in baselines.json) survives --resume; a resume that
  # fails leaves the manifest's status truthful (never "running").
  out="$tmp/r"
  ROSGUARD_FAKE_SLEEP_MS=100 "$bin" run $scenario --backend hw --out "$out" --quiet 2>/dev/null &
  pid=$!
  wait_rows "$out" 2
  kill -INT $pid
  wait $pid
  [[ $? -eq 130 ]] || fail "SIGINT did not give exit 130"
  set_ipc() {
    /usr/bin/python3 - "$out/baselines.json" "$1" <<'PY'
import json, sys
b = json.load(open(sys.argv[1]))
for v in b.values():
    for r in v["runs"]:
        r["ipc"] = json.loads(sys.argv[2])
json.dump(b, open(sys.argv[1], "w"))
PY
  }
  set_ipc '"fast"'
  "$bin" run $scenario --backend hw --out "$out" --resume --quiet 2> "$tmp/err"
  rc=$?
  [[ $rc -eq 1 ]] || fail "a corrupt baselines.json: exit $rc, expected 1"
  grep -q "baselines.json" "$tmp/err" || fail "the error does not name baselines.json: $(cat "$tmp/err")"
  grep -q "internal" "$tmp/err" && fail "$(cat "$tmp/err")"
  [[ $(status "$out") == interrupted ]] || fail "status after a failed resume: $(status "$out")"
  set_ipc null
  "$bin" run $scenario --backend hw --out "$out" --resume --quiet 2> "$tmp/err" ||
    fail "resume with ipc null: $(cat "$tmp/err")"
  [[ $(rows "$out") -eq 24 ]] || fail "$(rows "$out") rows after resume"
  [[ $(status "$out") == complete ]] || fail "status after resume: $(status "$out")"
  grep -q '"ipc": null' "$out/baselines.json" || fail "null ipc not kept in baselines.json"
  ;;
baselines)
  # hw: every baseline measured max(repetitions, 3) = 3 times, each measurement kept, the rows
  # with their median and spread; a spread above 5 % warned about on stderr and in the manifest.
  # A baselines.json of a rosguard before repeated baselines (one value per key) still resumes.
  out="$tmp/b"
  ROSGUARD_FAKE_ISO_SPREAD=0.1 "$bin" run $scenario --backend hw --out "$out" --quiet 2> "$tmp/err" ||
    fail "noisy run: $(cat "$tmp/err")"
  grep -q "warning: isolation baseline .* varies by 10.0 %" "$tmp/err" ||
    fail "no noise warning on stderr: $(cat "$tmp/err")"
  /usr/bin/python3 - "$out" <<'PY' || fail "noisy run: wrong baselines, rows or manifest"
import csv, json, statistics, sys
out = sys.argv[1]
b = json.load(open(f"{out}/baselines.json"))
m = json.load(open(f"{out}/manifest.json"))
rows = list(csv.DictReader(open(f"{out}/points.csv")))
for key, v in b.items():
    times = [r["time_us"] for r in v["runs"]]
    assert [r["rep"] for r in v["runs"]] == [0, 1, 2], v
    assert v["time_us"] == statistics.median(times), v
    assert abs(v["time_cv"] - statistics.stdev(times) / statistics.mean(times)) < 1e-9, v
    assert m["baselines"][key]["measurements"] == 3
    assert any(w.startswith(f"isolation baseline {key}:") for w in m["warnings"]), m["warnings"]
for r in rows:
    assert r["rt_isolation_n"] == "3" and r["nrt_isolation_n"] == "3", r
    assert abs(float(r["rt_isolation_cv"]) - 0.1) < 1e-6, r
    med = [v["time_us"] for k, v in b.items() if k.startswith("fake/core1/")][0]
    assert abs(float(r["rt_isolation_us"]) - med) < 1e-3, r
    assert abs(float(r["rt_slowdown"]) - float(r["rt_time_us"]) / med) < 1e-5, r
PY
  # The older format: one value per key; the resumed run measures the other two and refreshes.
  out="$tmp/old"
  ROSGUARD_FAKE_SLEEP_MS=100 "$bin" run $scenario --backend hw --out "$out" --quiet 2>/dev/null &
  pid=$!
  wait_rows "$out" 2
  kill -INT $pid
  wait $pid
  /usr/bin/python3 - "$out/baselines.json" <<'PY'
import json, sys
b = json.load(open(sys.argv[1]))
json.dump({k: {f: v["runs"][0][f] for f in ("time_us", "ipc", "mbps")} for k, v in b.items()},
          open(sys.argv[1], "w"))
PY
  "$bin" run $scenario --backend hw --out "$out" --resume --quiet 2> "$tmp/err" ||
    fail "resume from a single-value baselines.json: $(cat "$tmp/err")"
  [[ $(rows "$out") -eq 24 ]] || fail "$(rows "$out") rows after resume"
  /usr/bin/python3 - "$out" <<'PY' || fail "resumed old format: not 3 measurements everywhere"
import csv, json, sys
b = json.load(open(f"{sys.argv[1]}/baselines.json"))
assert all(len(v["runs"]) == 3 for v in b.values()), b
assert all(r["rt_isolation_n"] == "3" for r in csv.DictReader(open(f"{sys.argv[1]}/points.csv")))
PY
  ;;
adjacent)
  # hw.adjacent_baselines: each point has baselines of its own, measured right before each of
  # its repetitions (in the fixed rounds and in adaptive ones), and each row divides by the
  # measurement taken before it; a resumed run keeps that pairing.
  for mode in fixed adaptive; do
    s="$tmp/adjacent-$mode.json"
    /usr/bin/python3 - tests/app/fixtures/sweep.json "$s" "$mode" <<'PY'
import json, os, sys
d = json.load(open(sys.argv[1]))
del d["$schema"]
for n in d["nodes"]["rt"] + d["nodes"]["nrt"]:  # written outside the fixtures' folder
    n["workload"] = os.path.abspath(os.path.join(os.path.dirname(sys.argv[1]), n["workload"]))
d["hw"] = {"adjacent_baselines": True}
if sys.argv[3] == "adaptive":
    d["hw"].update({"precision_pct": 50, "max_repetitions": 4})
json.dump(d, open(sys.argv[2], "w"))
PY
    out="$tmp/adj-$mode"
    rm -f "$tmp/order"
    ROSGUARD_FAKE_ISO_SPREAD=0.2 ROSGUARD_FAKE_ORDER="$tmp/order" \
      "$bin" run "$s" --backend hw --out "$out" --quiet 2> "$tmp/err" || fail "$mode: $(cat "$tmp/err")"
    /usr/bin/python3 - "$out" "$tmp/order" <<'PY' || fail "$mode: adjacent baselines"
import csv, json, sys
out, order = sys.argv[1], open(sys.argv[2]).read().split("\n")[:-1]
b = json.load(open(f"{out}/baselines.json"))
rows = list(csv.DictReader(open(f"{out}/points.csv")))
u = json.load(open(f"{out}/unregulated.json"))
points = {r["point"] for r in rows}
# One RT and one nRT baseline per point and per unregulated co-run.
assert len(b) == 2 * (len(points) + len(u)), (len(b), len(points), len(u))
# Every run (point or co-run) is preceded by its own two baselines, measured just before it.
for i, line in enumerate(order):
    if line.startswith("point"):
        assert order[i - 2:i] == ["iso 1", "iso 2"], order[max(0, i - 3):i + 1]
runs = sum(len(v["runs"]) for v in u.values())
assert sum(l.startswith("point") for l in order) == len(rows) + runs, (len(order), len(rows))
assert all(r["rt_unregulated_slowdown"] for r in rows if r["policy"] != "none"), rows[0]
for r in rows:
    rep = int(r["rep"])
    for side, core in (("rt", 1), ("nrt", 2)):
        mine = [v for k, v in b.items() if k.startswith(f"fake/core{core}/") and
                any(x["rep"] == rep for x in v["runs"]) and
                abs(next(x["time_us"] for x in v["runs"] if x["rep"] == rep) -
                    float(r[f"{side}_isolation_us"])) < 1e-3]
        assert mine, (r["point"], rep, side)
        assert abs(float(r[f"{side}_slowdown"]) - float(r[f"{side}_time_us"]) /
                   float(r[f"{side}_isolation_us"])) < 1e-5, r
# The spread (1 - s, 1, 1 + s by call) reaches the rows: not every row has the median.
assert len({r["rt_isolation_us"] for r in rows}) > 1
PY
  done
  ;;
failure)
  # A failing point: exit 1, status failed, the error in the manifest, complete rows kept.
  ROSGUARD_FAKE_FAIL_AT=15 "$bin" run $scenario --out "$tmp/f" --jobs 1 --quiet 2> "$tmp/err"
  rc=$?
  [[ $rc -eq 1 ]] || fail "exit $rc, expected 1"
  grep -q "fake failure at threshold 15" "$tmp/err" || fail "error not reported: $(cat "$tmp/err")"
  [[ $(status "$tmp/f") == failed ]] || fail "status $(status "$tmp/f")"
  complete_rows "$tmp/f"
  [[ $(rows "$tmp/f") -ge 4 ]] || fail "rows before the failure were not kept"
  ;;
folders)
  # An existing results folder is never overwritten by accident.
  "$bin" run $scenario --out "$tmp/o" --quiet || fail "first run"
  "$bin" run $scenario --out "$tmp/o" --quiet 2> "$tmp/err"
  [[ $? -eq 2 ]] || fail "rerun into a used folder should exit 2"
  grep -q -- "--resume" "$tmp/err" || fail "message should mention --resume"
  "$bin" run $scenario --out "$tmp/o" --overwrite --quiet || fail "--overwrite"
  [[ $(rows "$tmp/o") -eq 24 ]] || fail "--overwrite left $(rows "$tmp/o") rows"
  sed 's/25, 30/25, 35/' $scenario > tests/app/fixtures/.changed-$$.json
  "$bin" run tests/app/fixtures/.changed-$$.json --out "$tmp/o" --resume --quiet 2> "$tmp/err"
  rc=$?
  rm -f tests/app/fixtures/.changed-$$.json
  [[ $rc -eq 2 ]] || fail "resuming a different scenario should exit 2, got $rc"
  grep -q "different scenario" "$tmp/err" || fail "message: $(cat "$tmp/err")"
  "$bin" run $scenario --out "$tmp/o" --resume --overwrite 2>/dev/null
  [[ $? -eq 2 ]] || fail "--resume with --overwrite should exit 2"
  for bad in "--shard 2/2" "--shard 1/99999999999" "--shard 99999999999/2" "--shard -1/2" \
             "--shard 1/2/3" "--jobs 99999999999" "--jobs 0"; do
    "$bin" run $scenario --out "$tmp/o2" $bad 2> "$tmp/err"
    rc=$?
    [[ $rc -eq 2 ]] || fail "$bad should exit 2, got $rc"
    grep -q "internal" "$tmp/err" && fail "$bad: $(cat "$tmp/err")"
    grep -q -- "${bad%% *}" "$tmp/err" || fail "$bad: the message does not name the option"
  done
  [[ ! -e "$tmp/o2" ]] || fail "a usage error created the results folder"
  ;;
progress)
  # stderr not a terminal: plain progress lines (no carriage returns), counting runs only, the
  # last one at the total; no .lock is left behind.
  ROSGUARD_FAKE_SLEEP_MS=20 "$bin" run $scenario --out "$tmp/p" --jobs 1 2> "$tmp/err" ||
    fail "run: $(cat "$tmp/err")"
  grep -q $'\r' "$tmp/err" && fail "carriage returns in a non-terminal progress output"
  [[ $(grep -c '^progress: \[' "$tmp/err") -ge 2 ]] || fail "no periodic lines: $(cat "$tmp/err")"
  grep '^progress: ' "$tmp/err" | tail -1 | grep -q '^progress: \[24/24 runs\] 100%' ||
    fail "last progress line: $(grep '^progress: ' "$tmp/err" | tail -1)"
  [[ ! -e "$tmp/p/.lock" ]] || fail "the finished run left its .lock"
  "$bin" run $scenario --out "$tmp/q" --quiet 2> "$tmp/err2" || fail "quiet run"
  grep -q '^progress:' "$tmp/err2" && fail "--quiet printed progress"
  ;;
trace)
  # --trace writes a Chrome trace with one process per point and repetition.
  "$bin" run $scenario --out "$tmp/t" --trace --quiet || fail "run"
  /usr/bin/python3 - "$tmp/t/trace.json" <<'PY' || fail "trace.json is not a valid Chrome trace"
import json, sys
t = json.load(open(sys.argv[1]))
ev = t["traceEvents"]
names = {e["args"]["name"] for e in ev if e.get("name") == "process_name"}
assert len(names) == 24, len(names)
assert {"X", "C", "i", "M"} <= {e["ph"] for e in ev}
assert all("ts" in e for e in ev if e["ph"] != "M")
PY
  ;;
manifest)
  # The manifest describes the run: tool, host, scenario (given and expanded), counts.
  "$bin" run $scenario --out "$tmp/m" --quiet || fail "run"
  /usr/bin/python3 - "$tmp/m/manifest.json" <<'PY' || fail "manifest incomplete"
import json, sys
m = json.load(open(sys.argv[1]))
for k in ["tool", "host", "scenario", "platform", "backend", "seed", "start_time", "end_time",
          "fallbacks", "counts", "scenario_hash"]:
    assert k in m, k
assert m["tool"]["git_revision"], m["tool"]
assert m["scenario"]["expanded"]["regulation"]["scope"] == "core"  # a schema default
# sampling defaults by policy, per point (policy_defaults): the expanded base leaves it unset
assert "sampling" not in m["scenario"]["expanded"]["regulation"]
assert len(m["scenario"]["points"]) == 12
assert m["counts"]["rows"] == 24 and m["status"] == "complete"
PY
  # columns.json: unit and meaning of exactly the columns points.csv has, in order.
  /usr/bin/python3 - "$tmp/m" <<'PY' || fail "columns.json does not describe points.csv"
import json, sys
d = json.load(open(sys.argv[1] + "/columns.json"))
header = open(sys.argv[1] + "/points.csv").readline().strip().split(",")
assert [c["name"] for c in d["points.csv"]] == header, d["points.csv"]
assert all(c["unit"] and c["meaning"] for c in d["points.csv"] + d["samples.csv"])
assert {c["name"]: c["unit"] for c in d["points.csv"]}["nrt_bandwidth_mbps"] == "MiB/s"
PY
  ;;
resume_twice)
  # One writer per shard (issue 23): a second `run --resume` of the shard that another rosguard
  # is writing into the same folder exits 4, names the first one (its pid) and writes nothing;
  # the first finishes with every run's row and samples once, as a single run writes them. (Both
  # used to run the missing runs: samples.csv kept both copies.) A writer killed with SIGKILL
  # leaves its lock file but not its lock.
  "$bin" run $scenario --out "$tmp/ref" --quiet || fail "reference run"
  ROSGUARD_FAKE_SLEEP_MS=100 "$bin" run $scenario --out "$tmp/r" --resume --jobs 1 --quiet &
  pid=$!
  wait_rows "$tmp/r" 1
  ROSGUARD_FAKE_SLEEP_MS=100 "$bin" run $scenario --out "$tmp/r" --resume --jobs 1 --quiet \
    2> "$tmp/err"
  rc=$?
  echo "second writer: exit $rc: $(cat "$tmp/err")"
  [[ $rc -eq 4 ]] || fail "a second writer of shard 0/1: exit $rc, expected 4"
  grep -q "^error: another rosguard (pid $pid on [^,]*, since [^)]*) is writing shard 0 of 1 into $tmp/r; " \
    "$tmp/err" || fail "the refusal does not name the writer and the shard"
  wait $pid || fail "the first writer exited $?"
  echo "samples.csv: $(wc -l < "$tmp/r/samples.csv") lines, a single run: $(wc -l < "$tmp/ref/samples.csv")"
  cmp "$tmp/ref/points.csv" "$tmp/r/points.csv" || fail "points.csv differs from a single run"
  cmp "$tmp/ref/samples.csv" "$tmp/r/samples.csv" || fail "samples.csv differs from a single run"
  /usr/bin/python3 - "$tmp/r/manifest.json" "$pid" <<'PY' || fail "the refused writer changed the manifest"
import json, sys
m = json.load(open(sys.argv[1]))
assert m["status"] == "complete", m["status"]
assert list(m["shards"]) == ["0/1"], m["shards"]
assert m["shards"]["0/1"]["pid"] == int(sys.argv[2]), m["shards"]["0/1"]
assert m["counts"]["rows_this_invocation"] == 24, m["counts"]
PY
  [[ -z $(find "$tmp/r" -name '.shard-*') ]] || fail "the finished writer left its lock file"
  # Killed: its lock goes with it; the next writer of the shard runs.
  ROSGUARD_FAKE_SLEEP_MS=100 setsid "$bin" run $scenario --out "$tmp/k" --jobs 1 --quiet &
  pid=$!
  wait_rows "$tmp/k" 1
  kill -9 -- -$pid 2>/dev/null || kill -9 $pid
  wait $pid 2>/dev/null
  [[ -e "$tmp/k/.shard-0-of-1.lock" ]] || fail "no lock file while shard 0/1 ran"
  "$bin" run $scenario --out "$tmp/k" --resume --quiet 2>/dev/null || fail "resume after SIGKILL"
  cmp "$tmp/ref/samples.csv" "$tmp/k/samples.csv" || fail "resumed samples.csv differs"
  ;;
results_disk_full)
  # A write that fails ends the run: exit 1, the file and the OS error named, the manifest's
  # shard failed with that error (not "running": `rosguard status` said "killed?"), and a
  # --resume completes the folder as a single run writes it. The disk fills up while the run
  # goes on: a file size limit (RLIMIT_FSIZE, set on the running process with prlimit) between
  # the manifest's size and the CSV files' makes every write that grows the CSV files fail with
  # EFBIG, through the same write(2) path as ENOSPC, for any user and on any filesystem. With
  # SIGXFSZ ignored, write(2) returns the error instead of the signal killing the process.
  trap '' XFSZ
  s=tests/app/fixtures/.disk-$$.json
  trap 'rm -rf "$tmp" '"$s" EXIT
  sed 's/"repetitions": 2,/"repetitions": 40,/' $scenario > "$s"
  "$bin" run "$s" --out "$tmp/ref" --quiet || fail "reference run"
  size() { stat -c %s "$1" 2>/dev/null || echo 0; }
  limit() {  # limit PID BYTES: the process's soft file size limit
    /usr/bin/python3 -c '
import resource, sys
pid, limit = int(sys.argv[1]), int(sys.argv[2])
hard = resource.prlimit(pid, resource.RLIMIT_FSIZE)[1]
resource.prlimit(pid, resource.RLIMIT_FSIZE, (limit, hard))' "$1" "$2"
  }
  # start_full DIR BYTES: a run into DIR whose files may not grow past BYTES once points.csv and
  # samples.csv have; sets pid.
  start_full() {
    ROSGUARD_FAKE_SLEEP_MS=10 "$bin" run "$s" --out "$1" --jobs 1 --quiet 2> "$1.err" &
    pid=$!
    for _ in $(seq 600); do
      [[ $(size "$1/points.csv") -gt $2 && $(size "$1/samples.csv") -gt $2 ]] && break
      sleep 0.05
    done
    limit $pid "$2" || fail "cannot set the file size limit of pid $pid"
    [[ $(rows "$1") -lt 480 ]] || fail "the run finished before its disk was full"
  }
  # The manifest can be written (with room for the error), the CSV files cannot.
  start_full "$tmp/d" $(($(size "$tmp/ref/manifest.json") + 8192))
  wait $pid
  rc=$?
  echo "run: exit $rc: $(cat "$tmp/d.err")"
  [[ $rc -eq 1 ]] || fail "exit $rc after a failed write, expected 1"
  grep -Eq "^error: cannot write $tmp/d/(samples|points)\.csv: File too large$" "$tmp/d.err" ||
    fail "the error does not name the file and the OS error"
  [[ $(status "$tmp/d") == failed ]] || fail "manifest status $(status "$tmp/d"), expected failed"
  /usr/bin/python3 - "$tmp/d/manifest.json" <<'PY' || fail "the manifest does not record the error"
import json, sys
m = json.load(open(sys.argv[1]))
e = m["shards"]["0/1"]
assert e["status"] == "failed" and "File too large" in e["error"], e
assert m["error"] == e["error"], m.get("error")
PY
  "$bin" status "$tmp/d" > "$tmp/status" || fail "status"
  echo "status: $(cat "$tmp/status")"
  grep -Eq "^  0/1 .* failed: cannot write $tmp/d/(samples|points)\.csv: File too large$" \
    "$tmp/status" || fail "status does not show the error"
  [[ -z $(tail -c 1 "$tmp/d/samples.csv") ]] || fail "samples.csv ends in a torn line"
  "$bin" run "$s" --out "$tmp/d" --resume --quiet || fail "resume after the disk error"
  cmp "$tmp/ref/points.csv" "$tmp/d/points.csv" || fail "resumed points.csv differs"
  cmp "$tmp/ref/samples.csv" "$tmp/d/samples.csv" || fail "resumed samples.csv differs"
  # Nothing can be written, the manifest neither: stderr says that it still says running.
  start_full "$tmp/e" 4096
  wait $pid
  rc=$?
  echo "run: exit $rc: $(cat "$tmp/e.err")"
  [[ $rc -eq 1 ]] || fail "exit $rc after a failed write, expected 1"
  grep -q "^error: could not record the failure in $tmp/e/manifest.json (cannot write $tmp/e/manifest.json: File too large): it still says that shard 0/1 is running$" \
    "$tmp/e.err" || fail "stderr does not say that the manifest could not record the failure"
  grep -Eq "^error: cannot write $tmp/e/(samples|points)\.csv: File too large$" "$tmp/e.err" ||
    fail "the write error is not named"
  ;;
seed)
  # The seed is a u64: 2^64 - 1 is valid (it was "must be >= 0": valijson read it as -1) and
  # goes into the manifest exactly; the runs differ from those of seed 1.
  sed 's/"name": "runner-test",/"name": "runner-test", "seed": 18446744073709551615,/' \
    $scenario > tests/app/fixtures/.seed-$$.json
  trap 'rm -rf "$tmp" tests/app/fixtures/.seed-$$.json' EXIT
  "$bin" check tests/app/fixtures/.seed-$$.json > "$tmp/out" 2>&1 || fail "check: $(cat "$tmp/out")"
  "$bin" run tests/app/fixtures/.seed-$$.json --out "$tmp/s" --quiet || fail "run"
  "$bin" run $scenario --out "$tmp/one" --quiet || fail "run with seed 1"
  /usr/bin/python3 - "$tmp/s/manifest.json" <<'PY' || fail "the seed is not in the manifest exactly"
import json, sys
m = json.load(open(sys.argv[1]))
assert m["seed"] == 2**64 - 1, m["seed"]
assert m["scenario"]["expanded"]["seed"] == 2**64 - 1, m["scenario"]["expanded"]["seed"]
assert m["status"] == "complete", m["status"]
PY
  grep -q '"seed": 18446744073709551615,' "$tmp/s/manifest.json" || fail "manifest: $(grep seed "$tmp/s/manifest.json")"
  cmp -s "$tmp/s/samples.csv" "$tmp/one/samples.csv" && fail "seed 2^64 - 1 gave the samples of seed 1"
  ;;
list)
  # `list` alone shows every catalogue; `list KIND` one; an unknown kind is a usage error.
  "$bin" list > "$tmp/all" || fail "list"
  for section in workloads platforms policies backends "pmc sources"; do
    grep -q "^$section" "$tmp/all" || fail "list without a kind lacks '$section'"
  done
  grep -q "^  bandwidth_read " "$tmp/all" || fail "list lacks the workload bandwidth_read"
  "$bin" list policies > "$tmp/one" || fail "list policies"
  [[ $(grep -c '^[a-z]' "$tmp/one") -eq 1 ]] || fail "list policies printed other sections"
  grep -q "^  monolithic " "$tmp/one" || fail "list policies lacks monolithic"
  "$bin" list bogus > /dev/null 2> "$tmp/err"
  [[ $? -eq 2 ]] || fail "list bogus should exit 2"
  grep -q "bogus" "$tmp/err" || fail "list bogus does not name the bad kind"
  ;;
precision)
  # hw.precision_pct (adaptive rounds) on the fake hw backend, whose co-run times carry 1 %
  # noise: a loose target stops every point after the minimum 3 rounds, a target the noise
  # cannot reach at the cap; one baseline measurement per round; every row with its point's
  # slowdown CIs; the manifest and the summary line say what was reached; a resume with a higher
  # cap adds rounds; sim runs the fixed repetitions and leaves the CI cells empty.
  make() {  # make FILE PRECISION CAP
    /usr/bin/python3 - "$scenario" "$1" "$2" "$3" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
s["repetitions"] = 1
s["hw"] = {"precision_pct": float(sys.argv[3]), "max_repetitions": int(sys.argv[4])}
json.dump(s, open(sys.argv[2], "w"))
PY
  }
  trap 'rm -rf "$tmp" tests/app/fixtures/precision-*.json' EXIT
  make tests/app/fixtures/precision-loose.json 50 5
  make tests/app/fixtures/precision-tight.json 0.0001 4
  make tests/app/fixtures/precision-tight-more.json 0.0001 6
  check() {  # check DIR ROUNDS VERDICT TARGET
    /usr/bin/python3 - "$@" <<'PY' || fail "$1: wrong rounds, CIs or manifest"
import collections, csv, json, sys
out, rounds, verdict, target = sys.argv[1], int(sys.argv[2]), sys.argv[3], float(sys.argv[4])
rows = list(csv.DictReader(open(f"{out}/points.csv")))
per_point = collections.Counter(r["point"] for r in rows)
assert len(per_point) == 12 and set(per_point.values()) == {rounds}, per_point
for r in rows:
    for c in ("rt_slowdown_ci95_pct", "nrt_slowdown_ci95_pct"):
        assert r[c] != "" and float(r[c]) >= 0.0, (c, r)
    assert float(r["rt_slowdown_ci95_pct"]) > 0.0, r          # 1 % noise
    assert r["rt_isolation_n"] == str(rounds), r              # one baseline per round
b = json.load(open(f"{out}/baselines.json"))
assert all([x["rep"] for x in v["runs"]] == list(range(rounds)) for v in b.values()), b
u = json.load(open(f"{out}/unregulated.json"))
assert all(len(v["runs"]) == 3 for v in u.values()), u      # the co-run: the first 3 rounds
m = json.load(open(f"{out}/manifest.json"))
assert m["status"] == "complete", m["status"]
p = m["precision"]
assert p["target_pct"] == target and len(p["points"]) == 12, p
for e in p["points"].values():
    assert e["repetitions"] == rounds and e["verdict"] == verdict, e
    if verdict == "precise":
        assert e["rt_slowdown_ci95_pct"] <= target and e["nrt_slowdown_ci95_pct"] <= target, e
    else:
        assert e["rt_slowdown_ci95_pct"] > target, e
PY
  }
  "$bin" run tests/app/fixtures/precision-loose.json --backend hw --out "$tmp/loose" > "$tmp/out" \
    2>/dev/null || fail "loose run"
  check "$tmp/loose" 3 precise 50
  grep -q "x 3 repetition(s) written .*; slowdown 95 % CI within 50 % on 12 of 12 point(s)" \
    "$tmp/out" || fail "summary line: $(cat "$tmp/out")"
  "$bin" run tests/app/fixtures/precision-tight.json --backend hw --out "$tmp/tight" > "$tmp/out" \
    2>/dev/null || fail "tight run"
  check "$tmp/tight" 4 capped 0.0001
  grep -q "within 0.0001 % on 0 of 12 point(s) .*, 12 stopped at the cap" "$tmp/out" ||
    fail "summary line: $(cat "$tmp/out")"
  # The same folder resumed with a higher cap: two more rounds, nothing measured twice.
  "$bin" run tests/app/fixtures/precision-tight-more.json --backend hw --out "$tmp/tight" --resume \
    --quiet 2>/dev/null || fail "resume with a higher cap"
  check "$tmp/tight" 6 capped 0.0001
  # sim: deterministic, the fixed repetitions, empty CI cells, no precision in the manifest.
  "$bin" run tests/app/fixtures/precision-tight.json --out "$tmp/sim" --quiet || fail "sim run"
  [[ $(rows "$tmp/sim") -eq 12 ]] || fail "sim: $(rows "$tmp/sim") rows"
  /usr/bin/python3 - "$tmp/sim" <<'PY' || fail "sim: CI cells or manifest"
import csv, json, sys
rows = list(csv.DictReader(open(f"{sys.argv[1]}/points.csv")))
assert all(r["rt_slowdown_ci95_pct"] == "" and r["nrt_slowdown_ci95_pct"] == "" for r in rows)
assert "precision" not in json.load(open(f"{sys.argv[1]}/manifest.json"))
PY
  ;;
unregulated)
  # The unregulated co-run (tools/rosguard/run/unregulated.h): measured once per co-run key, not
  # per threshold or policy (sim: once; hw: as the baselines, 3 times), written into every
  # row; a policy-none point carries its own values; kept over a resume; off with
  # --no-unregulated.
  sed 's/"monolithic"\]/"monolithic", "none"]/' $scenario > tests/app/fixtures/unregulated.json
  trap 'rm -rf "$tmp" tests/app/fixtures/unregulated.json' EXIT
  check() {  # check DIR MEASUREMENTS
    /usr/bin/python3 - "$1" "$2" <<'PY' || fail "$1: wrong unregulated co-run"
import csv, json, statistics, sys
out, n = sys.argv[1], int(sys.argv[2])
u = json.load(open(f"{out}/unregulated.json"))
assert len(u) == 1, u                         # one workload pair: one co-run
(key, v), = u.items()
assert key.startswith("corun/fake+fake/"), key
assert [r["rep"] for r in v["runs"]] == list(range(n)), v
rt = statistics.median(r["rt_time_us"][0] for r in v["runs"])
nrt = statistics.median(r["nrt_time_us"][0] for r in v["runs"])
assert abs(v["rt_time_us"][0] - rt) < 1e-9 and abs(v["nrt_time_us"][0] - nrt) < 1e-9, v
rows = list(csv.DictReader(open(f"{out}/points.csv")))
assert len(rows) == 36, len(rows)
for r in rows:
    if r["policy"] == "none":                 # its own co-run
        for node in ("rt", "nrt"):
            assert r[f"{node}_unregulated_time_us"] == r[f"{node}_time_us"], r
            assert r[f"{node}_unregulated_slowdown"] == r[f"{node}_slowdown"], r
        continue
    assert abs(float(r["rt_unregulated_time_us"]) - rt) < 1e-3, r
    assert abs(float(r["nrt_unregulated_time_us"]) - nrt) < 1e-3, r
    for node in ("rt", "nrt"):
        ratio = float(r[f"{node}_unregulated_time_us"]) / float(r[f"{node}_isolation_us"])
        assert abs(float(r[f"{node}_unregulated_slowdown"]) - ratio) < 1e-5, r
m = json.load(open(f"{out}/manifest.json"))
assert m["facts"]["unregulated_corun"].startswith("measured once"), m["facts"]
PY
  }
  s=tests/app/fixtures/unregulated.json
  "$bin" run $s --out "$tmp/sim" --quiet || fail "sim run"
  check "$tmp/sim" 1
  "$bin" run $s --backend hw --out "$tmp/hw" --quiet 2>/dev/null || fail "hw run"
  check "$tmp/hw" 3
  # Shards into one folder and a single run give the same bytes (whichever point a shard
  # takes its co-run from).
  "$bin" run $s --out "$tmp/sh" --shard 1/2 --quiet || fail "shard 1/2"
  "$bin" run $s --out "$tmp/sh" --shard 0/2 --quiet || fail "shard 0/2"
  cmp "$tmp/sim/points.csv" "$tmp/sh/points.csv" || fail "sharded points.csv differs"
  # Interrupted after the co-runs, resumed: the measurements are kept, every row filled.
  ROSGUARD_FAKE_SLEEP_MS=100 "$bin" run $s --backend hw --out "$tmp/r" --quiet 2>/dev/null &
  pid=$!
  wait_rows "$tmp/r" 2
  kill -INT $pid
  wait $pid
  [[ -f "$tmp/r/unregulated.json" ]] || fail "no unregulated.json after the first rows"
  cp "$tmp/r/unregulated.json" "$tmp/before.json"
  held=$(/usr/bin/python3 -c "import json,sys; print(sum(len(v['runs']) for v in json.load(open(sys.argv[1])).values()))" "$tmp/before.json")
  done_rows=$(rows "$tmp/r")
  ROSGUARD_FAKE_CALLS="$tmp/calls" "$bin" run $s --backend hw --out "$tmp/r" --resume --quiet \
    2>/dev/null || fail "resume"
  check "$tmp/r" 3
  # The resume ran the missing rows and only the co-run measurements it did not have.
  [[ $(wc -l < "$tmp/calls") -eq $((36 - done_rows + 3 - held)) ]] ||
    fail "resume: $(wc -l < "$tmp/calls") runs for $((36 - done_rows)) rows and $((3 - held)) co-run(s)"
  # (hw: measurement k runs before repetition round floor(k x 2 / 3): the third one may come
  # only with the resume; those taken before are kept as they were.)
  /usr/bin/python3 - "$tmp/before.json" "$tmp/r/unregulated.json" <<'PY' ||
import json, sys
before, after = (json.load(open(f)) for f in sys.argv[1:])
for key, v in before.items():
    assert v["runs"], v
    for run in v["runs"]:
        assert run in after[key]["runs"], (run, after[key]["runs"])
PY
    fail "the resume replaced co-run measurements it had"
  # Off: no co-run, empty cells, the manifest says so.
  "$bin" run $s --out "$tmp/off" --no-unregulated --quiet || fail "--no-unregulated"
  [[ ! -e "$tmp/off/unregulated.json" ]] || fail "--no-unregulated wrote unregulated.json"
  /usr/bin/python3 - "$tmp/off" <<'PY' || fail "--no-unregulated: cells or manifest"
import csv, json, sys
rows = list(csv.DictReader(open(f"{sys.argv[1]}/points.csv")))
assert all(r["rt_unregulated_slowdown"] == "" for r in rows if r["policy"] != "none")
assert json.load(open(f"{sys.argv[1]}/manifest.json"))["facts"]["unregulated_corun"].startswith("off")
PY
  ;;
check_json)
  # check --json: the text summary's numbers as one JSON object, every point with --points; an
  # invalid scenario prints nothing on stdout.
  "$bin" check $scenario > "$tmp/text" || fail "check"
  "$bin" check $scenario --json > "$tmp/j.json" || fail "check --json"
  "$bin" check $scenario --json --points > "$tmp/p.json" || fail "check --json --points"
  /usr/bin/python3 - "$tmp/j.json" "$tmp/p.json" "$tmp/text" <<'PY' || fail "check --json"
import json, sys
j, p, text = json.load(open(sys.argv[1])), json.load(open(sys.argv[2])), open(sys.argv[3]).read()
assert j["valid"] is True and j["name"] == "runner-test", j
assert f"{j['points']} points" in text.splitlines()[-1], (j["points"], text)
assert j["points"] == 12 and j["repetitions"] == 2 and j["runs"] == 24, j
assert [(s["key"], s["values"]) for s in j["sweep"]] == \
    [("regulation.threshold_pct", 6), ("regulation.policy", 2)], j["sweep"]
assert j["nodes"] == {"rt": 1, "nrt": 1, "controller_core": 0}, j["nodes"]
assert "point_list" not in j and len(p["point_list"]) == 12, p
assert len({q["id"] for q in p["point_list"]}) == 12
assert all(set(q["parameters"]) == {"regulation.threshold_pct", "regulation.policy"}
           for q in p["point_list"]), p["point_list"][0]
PY
  echo '{"name": "x", "nodes": 1}' > "$tmp/bad.json"
  "$bin" check "$tmp/bad.json" --json > "$tmp/bad.out" 2> "$tmp/bad.err"
  [[ $? -eq 2 && ! -s "$tmp/bad.out" && -s "$tmp/bad.err" ]] ||
    fail "an invalid scenario with --json: $(cat "$tmp/bad.out" "$tmp/bad.err")"
  # The loader's warnings reach run's console as check's, and the manifest (a controller on
  # the RT node's core).
  sed 's/"controller": { "core": 0 }/"controller": { "core": 1 }/' $scenario \
    > tests/app/fixtures/.shared-$$.json
  trap 'rm -rf "$tmp" tests/app/fixtures/.shared-$$.json' EXIT
  "$bin" check tests/app/fixtures/.shared-$$.json --json > "$tmp/w.json" 2> "$tmp/check.err" ||
    fail "check of the shared core"
  "$bin" run tests/app/fixtures/.shared-$$.json --out "$tmp/w" --quiet 2> "$tmp/run.err" ||
    fail "run of the shared core"
  warning="warning: the controller shares core 1 with node 'rt0'"
  grep -qF "$warning" "$tmp/check.err" || fail "check does not warn: $(cat "$tmp/check.err")"
  [[ $(grep -cF "$warning" "$tmp/run.err") -eq 1 ]] ||
    fail "run does not warn once: $(cat "$tmp/run.err")"
  /usr/bin/python3 - "$tmp/w.json" "$tmp/w/manifest.json" <<'PY' || fail "the warning's JSON"
import json, sys
j, m = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
assert any(w.startswith("the controller shares core 1 with node 'rt0'") for w in j["warnings"]), j
assert m["warnings"] == j["warnings"], (m["warnings"], j["warnings"])
PY
  ;;
*)
  fail "unknown case $case"
  ;;
esac
echo "ok: $case"

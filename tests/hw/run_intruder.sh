#!/usr/bin/env bash
# Issue 23 item 3: a hw run with transport dds cannot be hijacked. While a point runs, another
# process on the domain writes THR commands and an undefined command code to the nRT node's
# command topic, fake PMC samples to its pmc topic and 'false' / 'true' to the RT node's active
# topic. The run reads its own writers only: it ends as fast as without the intruder, exit 0,
# and its manifest says how many messages it ignored.
# Usage: run_intruder.sh ROSGUARD INTRUDER SOURCE_DIR
set -euo pipefail
rosguard=$1
intruder=$2
src=$3
tmp=$(mktemp -d)
run_pid="" intruder_pid=""
cleanup() {
  [[ -n "$run_pid" ]] && kill -9 "$run_pid" 2>/dev/null || true
  [[ -n "$intruder_pid" ]] && kill -9 "$intruder_pid" 2>/dev/null || true
  rm -rf "$tmp"
}
trap cleanup EXIT
ns="/rosguard_test_hijack_$$_${RANDOM}"
export CYCLONEDDS_URI="file://$src/tests/hw/cyclonedds-loopback.xml"
cat >"$tmp/s.json" <<JSON
{
  "name": "hw-test-intruder",
  "platform": "vm-2core",
  "backend": "hw",
  "repetitions": 1,
  "nodes": {
    "controller": { "core": 0 },
    "rt": [ { "name": "planner", "core": 0, "iterations": 10,
              "workload": { "name": "rt", "hw": { "kernel": "bandwidth_read", "working_set_kb": 4096, "passes": 2000 } } } ],
    "nrt": [ { "name": "nrt0", "core": 1,
               "workload": { "name": "nrt", "hw": { "kernel": "bandwidth_read", "working_set_kb": 4096, "passes": 400 } } } ]
  },
  "regulation": { "policy": "interval", "sampling": "self", "sampling_period_us": 1000,
                  "regulation_period_us": 5000, "threshold_pct": 20 },
  "hw": { "pmc_source": "auto", "baseline_repetitions": 1, "transport": "dds",
          "progress_timeout_ms": 20000, "dds": { "namespace": "$ns" } }
}
JSON
# Without the intruder: how long the run takes here.
t0=$(date +%s%N)
"$rosguard" run "$tmp/s.json" --out "$tmp/alone" --quiet >"$tmp/alone.log" 2>&1 ||
  { cat "$tmp/alone.log"; echo "FAIL: the run alone failed"; exit 1; }
alone_ms=$((($(date +%s%N) - t0) / 1000000))
# With it: the intruder waits for the point's readers (after the baselines), then writes. The
# few messages first, the floods last: on a busy machine a 20,000-command flood was still on its
# way when the point ended, and the run had then ignored nothing because nothing had reached it.
t0=$(date +%s%N)
"$rosguard" run "$tmp/s.json" --out "$tmp/attacked" --quiet >"$tmp/run.log" 2>&1 &
run_pid=$!
"$intruder" --ns "$ns" --wait-ms 60000 command nrt0 7 10 active planner 0 active planner 1 \
  pmc nrt0 5000 command nrt0 2 20000 >"$tmp/intruder.out" 2>&1 &
intruder_pid=$!
rc=0
wait "$run_pid" || rc=$?
run_pid=""
attacked_ms=$((($(date +%s%N) - t0) / 1000000))
kill "$intruder_pid" 2>/dev/null || true
wait "$intruder_pid" 2>/dev/null || true
intruder_pid=""
cat "$tmp/intruder.out" "$tmp/run.log"
echo "run alone ${alone_ms} ms, with the intruder ${attacked_ms} ms"
[[ $rc -eq 0 ]] || { echo "FAIL: the attacked run exited $rc"; exit 1; }
grep -q "matched 1" "$tmp/intruder.out" || { echo "FAIL: the intruder never met the run's readers"; exit 1; }
/usr/bin/python3 - "$tmp/attacked" "$alone_ms" "$attacked_ms" <<'PY'
import csv, json, sys
out, alone, attacked = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
m = json.load(open(f"{out}/manifest.json"))
fails = []
if m["status"] != "complete":
    fails.append(f"manifest status {m['status']}")
ignored = [f for f in m.get("fallbacks", []) if f["what"] == "ignored_messages"]
if not ignored:
    fails.append("no ignored_messages entry in the manifest's fallbacks")
else:
    print("manifest:", ignored[0]["detail"])
rows = list(csv.DictReader(open(f"{out}/points.csv")))
if len(rows) != 1 or rows[0]["rt_jobs"] != "10":
    fails.append(f"points.csv: {rows}")
# The intruder's writes cost the machine some time (DDS receive threads), but the point must
# not wait on them: within twice the run alone plus 10 s of slack for a busy machine.
if attacked > 2 * alone + 10000:
    fails.append(f"the attacked run took {attacked} ms against {alone} ms alone")
if fails:
    print("FAIL: " + "; ".join(fails))
    sys.exit(1)
PY
echo "OK: the run ignored the intruder and ended on time"

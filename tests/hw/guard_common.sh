# The set-up the guard's CLI tests share (guard_dds_cli.sh, guard_intruder.sh), sourced after
# `set -euo pipefail` with $rosguard and $src set: skips where stress-ng or a second CPU is
# missing; makes $tmp and, on exit, kills the guard, stress-ng and every pid in $extra_pids; a DDS
# namespace of this run alone ($ns) on the loopback interface.
# guard_start NAME [DDS_EXTRA]: writes $tmp/guard.json (RT node 'planner', nRT core 'be' = CPU 1 at 10 % of
# 1000 MB/s per 10 ms window, controller on CPU 0, DDS in and out), starts a stress-ng pinned on
# CPU 1 and the guard (log: $tmp/log), and waits until the guard regulates stress-ng. DDS_EXTRA:
# more keys of the configuration's "dds" object (JSON text).
command -v stress-ng >/dev/null || { echo "SKIPPED: stress-ng is not installed"; exit 0; }
[[ $(nproc) -ge 2 ]] || { echo "SKIPPED: needs two CPUs"; exit 0; }
tmp=$(mktemp -d)
guard_pid="" stress_pid="" extra_pids=""
guard_cleanup() {
  [[ -n "$guard_pid" ]] && kill -9 "$guard_pid" 2>/dev/null || true
  for p in $extra_pids; do kill -9 "$p" 2>/dev/null || true; done
  [[ -n "$stress_pid" ]] && kill -9 -- "-$stress_pid" 2>/dev/null || true
  rm -rf "$tmp"
}
trap guard_cleanup EXIT
ns="/rosguard_test_guard_$$_${RANDOM}"
export CYCLONEDDS_URI="file://$src/tests/hw/cyclonedds-loopback.xml"

guard_start() {
  cat >"$tmp/guard.json" <<JSON
{ "name": "$1", "controller": { "core": 0 }, "rt": [ { "name": "planner" } ],
  "nrt": [ { "name": "be", "core": 1 } ],
  "regulation": { "threshold_pct": 10, "reference_mbps": 1000, "regulation_period_us": 10000 },
  "hw": { "rescan_ms": 50 },
  "activity": { "source": "dds" }, "publish": { "transport": "dds" },
  "dds": { "namespace": "$ns"${2:+, $2} } }
JSON
  setsid taskset -c 1 stress-ng --cpu 1 --cpu-method int64 --timeout 120s --quiet &
  stress_pid=$!
  "$rosguard" guard "$tmp/guard.json" 2>"$tmp/log" &
  guard_pid=$!
  for _ in $(seq 200); do grep -q "regulating be (CPU 1)" "$tmp/log" && break; sleep 0.1; done
  grep -q "regulating be (CPU 1)" "$tmp/log" || { cat "$tmp/log"; echo "FAIL: guard did not start"; exit 1; }
  for _ in $(seq 50); do grep -q "regulating pid.*stress-ng" "$tmp/log" && break; sleep 0.1; done
}

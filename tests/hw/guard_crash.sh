#!/usr/bin/env bash
# Issue 23 item 4: nothing left crippled after a crash. For the idle and the freezer throttle: a
# guard regulates a pinned stress-ng while an RT node is active, and is killed (SIGKILL) with the
# process held (SCHED_IDLE; moved into a frozen cgroup). A new guard of the same name repairs what
# its record says (logged), and after its SIGTERM the process runs under its original policy in
# its original cgroup, and no rosguard-* cgroup is left.
# Usage: guard_crash.sh ROSGUARD SOURCE_DIR
set -euo pipefail
rosguard=$1
src=$2
command -v stress-ng >/dev/null || { echo "SKIPPED: stress-ng is not installed"; exit 0; }
[[ $(nproc) -ge 2 ]] || { echo "SKIPPED: needs two CPUs"; exit 0; }
[[ $(id -u) -eq 0 ]] || { echo "SKIPPED: SCHED_IDLE and cgroups of other processes need root"; exit 0; }
tmp=$(mktemp -d)
guard_pid="" stress_pid=""
cleanup() {
  [[ -n "$guard_pid" ]] && kill -9 "$guard_pid" 2>/dev/null || true
  if [[ -n "$stress_pid" ]]; then
    # A frozen process cannot die: thaw whatever holds it first.
    for f in "${mount:-/sys/fs/cgroup}"/rosguard-*/cgroup.freeze; do
      [[ -e $f ]] && echo 0 >"$f"
    done
    kill -9 -- "-$stress_pid" 2>/dev/null || true
  fi
  rm -rf "$tmp"
}
trap cleanup EXIT
# (|| true: no log, or an empty one, must not end the script before it says why)
fail() { echo "--- guard logs"; cat "$tmp"/log* 2>/dev/null | grep -v -- "-> THR\|-> ON" | tail -40 || true; echo "FAIL: $*"; exit 1; }
mount=$(awk '$9 == "cgroup2" { print $5; exit }' /proc/self/mountinfo)
[[ -n "$mount" ]] || { echo "SKIPPED: no cgroup v2 hierarchy"; exit 0; }

start_guard() {  # $1 throttle, $2 log
  "$rosguard" guard "$tmp/guard-$1.json" 2>"$tmp/$2" &
  guard_pid=$!
  for _ in $(seq 200); do grep -q "regulating be (CPU 1)" "$tmp/$2" && break; sleep 0.05; done
  grep -q "regulating be (CPU 1)" "$tmp/$2" || fail "guard ($1) did not start"
}
# stress-ng's worker: the child of this iteration's stress-ng (not one of an earlier that exits).
worker() { pgrep -P "$stress_pid" | head -1; }
worker_tids() { ls "/proc/$(worker)/task"; }
policies() { for t in $(worker_tids); do chrt -p "$t" | head -1 | sed 's/.*: //'; done | sort -u | tr '\n' ' '; }
cgroup_of() { sed -n 's/^0:://p' "/proc/$(worker)/cgroup"; }
cpu_ns() { awk '{print $1}' "/proc/$(worker)/schedstat"; }

for throttle in idle freezer; do
  cat >"$tmp/guard-$throttle.json" <<JSON
{ "name": "crash_$throttle", "controller": { "core": 0 }, "rt": [ { "name": "planner" } ],
  "nrt": [ { "name": "be", "core": 1 } ],
  "regulation": { "threshold_pct": 10, "reference_mbps": 1000, "regulation_period_us": 10000 },
  "hw": { "rescan_ms": 50, "throttle": "$throttle" },
  "state_dir": "$tmp/state",
  "activity": { "source": "fifo", "path": "$tmp/activity-$throttle" },
  "publish": { "transport": "none" } }
JSON
  setsid taskset -c 1 stress-ng --cpu 1 --cpu-method int64 --timeout 120s --quiet &
  stress_pid=$!
  for _ in $(seq 50); do [[ -n $(worker) ]] && break; sleep 0.05; done
  policy0=$(policies) cgroup0=$(cgroup_of)
  start_guard "$throttle" "log-$throttle-1"
  for _ in $(seq 100); do grep -q "regulating pid.*stress-ng-cpu" "$tmp/log-$throttle-1" && break; sleep 0.05; done
  echo "planner 1" >"$tmp/activity-$throttle"
  sleep 0.5
  kill -9 "$guard_pid"
  wait "$guard_pid" 2>/dev/null || true
  guard_pid=""
  held_policy=$(policies) held_cgroup=$(cgroup_of)
  echo "$throttle: before the guard: $policy0 in $cgroup0; after its SIGKILL: $held_policy in $held_cgroup"
  [[ -f "$tmp/state/crash_$throttle.record" ]] || fail "$throttle: the killed guard left no record"
  if [[ $throttle == idle ]]; then
    [[ $held_policy == *SCHED_IDLE* ]] || fail "idle: the killed guard did not leave SCHED_IDLE ($held_policy): nothing to repair"
  else
    [[ $held_cgroup == */rosguard-* ]] || fail "freezer: the killed guard did not leave the process in its cgroup ($held_cgroup)"
  fi
  start_guard "$throttle" "log-$throttle-2"
  grep "repaired after" "$tmp/log-$throttle-2" || fail "$throttle: the new guard logged no repair"
  sleep 0.3
  kill -TERM "$guard_pid"
  rc=0
  wait "$guard_pid" || rc=$?
  guard_pid=""
  [[ $rc -eq 0 ]] || fail "$throttle: the second guard exited $rc"
  policy1=$(policies) cgroup1=$(cgroup_of)
  echo "$throttle: after the second guard's SIGTERM: $policy1 in $cgroup1"
  [[ $policy1 == "$policy0" ]] || fail "$throttle: policy $policy1, was $policy0"
  [[ $cgroup1 == "$cgroup0" ]] || fail "$throttle: cgroup $cgroup1, was $cgroup0"
  left=$(find "$mount" -maxdepth 4 -type d -name 'rosguard-*' 2>/dev/null | head -5)
  [[ -z $left ]] || fail "$throttle: cgroups left: $left"
  [[ ! -e "$tmp/state/crash_$throttle.record" ]] || fail "$throttle: the record outlived a clean stop"
  c0=$(cpu_ns); sleep 0.3; c1=$(cpu_ns)
  ((c1 > c0)) || fail "$throttle: stress-ng does not run"
  kill -9 -- "-$stress_pid" 2>/dev/null || true
  wait "$stress_pid" 2>/dev/null || true
  for _ in $(seq 100); do pgrep -g "$stress_pid" >/dev/null || break; sleep 0.05; done
  stress_pid=""
done

# pin_processes: a killed guard leaves an unpinned process pinned to the nRT core; the next guard
# of the name gives its threads their CPUs back (logged), and so does its own clean stop.
cat >"$tmp/guard-pin.json" <<JSON
{ "name": "crash_pin", "controller": { "core": 0 }, "rt": [ { "name": "planner" } ],
  "nrt": [ { "name": "be", "core": 1 } ], "pin_processes": [ "stress-ng-cpu" ],
  "regulation": { "threshold_pct": 10, "reference_mbps": 1000, "regulation_period_us": 10000 },
  "hw": { "rescan_ms": 50 }, "state_dir": "$tmp/state",
  "activity": { "source": "fifo", "path": "$tmp/activity-pin" },
  "publish": { "transport": "none" } }
JSON
setsid stress-ng --cpu 2 --cpu-method int64 --timeout 120s --quiet &
stress_pid=$!
for _ in $(seq 50); do [[ $(pgrep -P "$stress_pid" | wc -l) -ge 2 ]] && break; sleep 0.05; done
affinity() { for p in $(pgrep -P "$stress_pid"); do taskset -pc "$p" | sed 's/.*: //'; done | sort -u | tr '\n' ' '; }
aff0=$(affinity)
start_guard pin log-pin-1
for _ in $(seq 100); do [[ $(grep -c "pinned to CPU 1" "$tmp/log-pin-1") -ge 2 ]] && break; sleep 0.05; done
kill -9 "$guard_pid"
wait "$guard_pid" 2>/dev/null || true
guard_pid=""
held=$(affinity)
echo "pin: before the guard: CPUs $aff0; after its SIGKILL: $held"
[[ $held == "1 " ]] || fail "pin: the killed guard did not leave the workers pinned to CPU 1 ($held)"
start_guard pin log-pin-2
grep "repaired after.*back to CPUs" "$tmp/log-pin-2" || fail "pin: the new guard logged no repair of the affinity"
sleep 0.3
kill -TERM "$guard_pid"
wait "$guard_pid" || fail "pin: the second guard exited $?"
guard_pid=""
aff1=$(affinity)
echo "pin: after the second guard's SIGTERM: CPUs $aff1"
[[ $aff1 == "$aff0" ]] || fail "pin: CPUs $aff1, were $aff0"
echo "OK: after SIGKILL and a new guard, nothing is left held (idle, freezer, pinned)"

#!/usr/bin/env bash
# Soak of `rosguard guard` under regulation (issue 23 item 5): a stress-ng pinned on the nRT core,
# an RT node active 300 ms of every 500 ms (named-pipe activity), for DURATION seconds. Every
# 10 s: the guard's resident memory (VmRSS) and its log's size. At the end: RSS after the first
# minute and at the end, its growth (per cent and kB per hour, least squares over the samples
# after the first minute) and the log's growth in bytes per hour at steady state (after the first
# minute), and the same for the anonymous part of RSS (heap, stacks: RssAnon) apart from the
# file-backed part (RssFile: pages of the binary and its libraries, which fault in as code runs for
# the first time and may be dropped and faulted in again by the page cache). Not a test: it
# asserts nothing about the machine; it says whether the goals hold
# (RSS growth < 1 % after the first minute, log < 1 MB per hour) and writes every sample to
# OUT/soak.csv.
# Usage: tests/bench/guard_soak.sh [BUILD_DIR] [DURATION_S] [OUT_DIR]   (defaults: build 1800 results/soak)
set -euo pipefail
build=${1:-build}
duration=${2:-1800}
out=${3:-results/soak}
exe="$build/rosguard"
[[ -x $exe ]] || { echo "error: $exe not found (build first: make build)" >&2; exit 2; }
command -v stress-ng >/dev/null || { echo "error: the soak needs stress-ng" >&2; exit 2; }
[[ $(nproc) -ge 2 ]] || { echo "error: the soak needs two CPUs" >&2; exit 2; }
((duration >= 120)) || { echo "error: DURATION_S must be at least 120 (the first minute is warm-up)" >&2; exit 2; }
mkdir -p "$out"
tmp=$(mktemp -d)
guard_pid="" stress_pid=""
cleanup() {
  [[ -n "$guard_pid" ]] && kill -TERM "$guard_pid" 2>/dev/null && wait "$guard_pid" 2>/dev/null || true
  [[ -n "$stress_pid" ]] && kill -9 -- "-$stress_pid" 2>/dev/null || true
  rm -rf "$tmp"
}
trap cleanup EXIT
last=$(($(nproc) - 1))
cat >"$tmp/guard.json" <<JSON
{ "name": "soak", "controller": { "core": 0 }, "rt": [ { "name": "planner" } ],
  "nrt": [ { "name": "be", "core": $last } ],
  "regulation": { "threshold_pct": 10, "reference_mbps": 1000, "regulation_period_us": 10000 },
  "state_dir": "$tmp/state",
  "activity": { "source": "fifo", "path": "$tmp/activity" }, "publish": { "transport": "dds" } }
JSON
setsid taskset -c "$last" stress-ng --cpu 1 --cpu-method int64 --timeout "$((duration + 60))s" --quiet &
stress_pid=$!
"$exe" guard "$tmp/guard.json" 2>"$out/guard.log" &
guard_pid=$!
for _ in $(seq 200); do grep -q "regulating be" "$out/guard.log" && break; sleep 0.05; done
grep -q "regulating be" "$out/guard.log" || { cat "$out/guard.log"; echo "error: the guard did not start" >&2; exit 1; }
exec 3>"$tmp/activity"
echo "t_s,rss_kb,rss_anon_kb,rss_file_kb,log_bytes" >"$out/soak.csv"
start=$(date +%s)
next=0
echo "soak: guard pid $guard_pid on CPU 0, stress-ng on CPU $last, ${duration} s; samples every 10 s in $out/soak.csv"
while :; do
  now=$(($(date +%s) - start))
  ((now >= duration)) && break
  if ((now >= next)); then
    read -r rss anon file < <(awk '/^VmRSS/ {r = $2} /^RssAnon/ {a = $2} /^RssFile/ {f = $2}
      END {print r, a, f}' "/proc/$guard_pid/status")
    echo "$now,$rss,$anon,$file,$(stat -c %s "$out/guard.log")" >>"$out/soak.csv"
    ((now % 300 < 10)) && echo "soak: ${now} s, RSS ${rss} kB, log $(stat -c %s "$out/guard.log") bytes"
    next=$((next + 10))
  fi
  echo "planner 1" >&3
  sleep 0.3
  echo "planner 0" >&3
  sleep 0.2
done
exec 3>&-
kill -TERM "$guard_pid"
wait "$guard_pid" || true
guard_pid=""
grep "totals:" "$out/guard.log" || true
/usr/bin/python3 - "$out/soak.csv" <<'PY'
import csv, sys
rows = [(float(r["t_s"]), float(r["rss_kb"]), float(r["log_bytes"]), float(r["rss_anon_kb"]),
         float(r["rss_file_kb"])) for r in csv.DictReader(open(sys.argv[1]))]
steady = [r for r in rows if r[0] >= 60]
if len(steady) < 3:
    sys.exit("soak: too few samples after the first minute")
t = [r[0] for r in steady]
def slope(ys):
    mt, my = sum(t) / len(t), sum(ys) / len(ys)
    return sum((a - mt) * (b - my) for a, b in zip(t, ys)) / sum((a - mt) ** 2 for a in t)
rss0, rss1 = steady[0][1], steady[-1][1]
growth = 100.0 * (rss1 - rss0) / rss0
rss_per_h = slope([r[1] for r in steady]) * 3600
log_per_h = slope([r[2] for r in steady]) * 3600
print(f"soak: {steady[-1][0] - steady[0][0]:.0f} s after the first minute: RSS {rss0:.0f} -> {rss1:.0f} kB "
      f"({growth:+.2f} %, trend {rss_per_h:+.0f} kB/h; goal < 1 %: {'met' if growth < 1.0 else 'MISSED'}); "
      f"log {log_per_h / 1e6:.3f} MB/h (goal < 1 MB/h: {'met' if log_per_h < 1e6 else 'MISSED'})")
for name, i in (("anonymous (RssAnon)", 3), ("file-backed (RssFile)", 4)):
    a0, a1 = steady[0][i], steady[-1][i]
    print(f"soak: {name}: {a0:.0f} -> {a1:.0f} kB ({100.0 * (a1 - a0) / a0:+.2f} %, "
          f"trend {slope([r[i] for r in steady]) * 3600:+.0f} kB/h)")
PY

#!/usr/bin/env bash
# Issue 54, item 3: `rosguard calibrate --transport rclcpp` takes the sim's message costs from
# rosguard_rclcpp's nodes: refitting the shipped VM measurements (--from) with the rclcpp costs
# measured here, the platform's publish_us, message_latency_us and throttle_activation_us are
# fitted to the rclcpp samples (their "source" says how many), the suite note names the bench, and
# local_message_latency_us is gone. Without a workspace (AMENT_PREFIX_PATH empty) it is refused,
# exit 2, and writes nothing.
# Usage: calibrate_rclcpp.sh ROSGUARD BUILD_DIR SOURCE_DIR DOMAIN
set -euo pipefail
rosguard=$1 build=$2 src=$3 domain=$4
# shellcheck source=ros2_common.sh
source "$src/tests/ros2/ros2_common.sh"
with_tmp
threads=$src/ros2/rosguard_rclcpp/config/cyclonedds-threads.xml
[[ -n $above ]] && export CYCLONEDDS_URI="$CYCLONEDDS_URI,file://$threads"
from=$src/docs/calibration/vm-2core/calibration.json

rc=0
AMENT_PREFIX_PATH="" ROSGUARD_RCLCPP_BENCH="" "$rosguard" calibrate --from "$from" \
  --transport rclcpp --out "$tmp/none" --quiet >"$tmp/none.log" 2>&1 || rc=$?
cat "$tmp/none.log"
[[ $rc -eq 2 ]] || { echo "FAIL: without a workspace: exit $rc, expected 2"; exit 1; }
grep -q "no sourced workspace has it" "$tmp/none.log" || { echo "FAIL: no reason given"; exit 1; }
[[ ! -e $tmp/none ]] || { echo "FAIL: the refused run created $tmp/none"; exit 1; }

"$rosguard" calibrate --from "$from" --transport rclcpp --quick --out "$tmp/cal" --quiet \
  >"$tmp/cal.log" 2>&1 || { cat "$tmp/cal.log"; echo "FAIL: calibrate --transport rclcpp"; exit 1; }
grep "rclcpp" "$tmp/cal.log"
/usr/bin/python3 - "$tmp/cal" "$from" <<'PY'
import json, sys
cal = json.load(open(f"{sys.argv[1]}/calibration.json"))
platform = json.load(open(f"{sys.argv[1]}/platform.json"))
before = json.load(open(sys.argv[2]))["measurements"]["costs_us"]
after = cal["measurements"]["costs_us"]
fails = []
notes = [n for n in cal["suite_notes"] if "rclcpp" in n]
if not notes:
    fails.append("no suite note names the rclcpp costs")
for key in ("pmc_callback", "publish", "message_latency", "throttle_activation"):
    if after.get(key) == before.get(key):
        fails.append(f"{key}: the samples are the shipped ones, not rclcpp's")
    n = len(after.get(key, []))
    source = platform["costs"][f"{key}_us"]["source"]
    if f"to {n} samples" not in source:
        fails.append(f"{key}_us: fitted to something else than the {n} rclcpp samples ({source})")
if "local_message_latency" in after or "local_message_latency_us" in platform["costs"]:
    fails.append("local_message_latency is still there")
if after.get("controller_callback") != before.get("controller_callback"):
    fails.append("controller_callback changed: it should stay the suite's")
print(notes[0] if notes else "")
for f in fails:
    print("FAIL:", f)
sys.exit(1 if fails else 0)
PY
echo "PASS"

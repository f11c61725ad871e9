#!/usr/bin/env bash
# Issue 54: one test case of the rosguard_rclcpp package's Catch2 tests
# (ros2/rosguard_rclcpp/test/), built by colcon against the ROS 2 Humble, on this test's own DDS
# domain. Cyclone's own threads run under SCHED_FIFO 55 (the package's
# config/cyclonedds-threads.xml) where SCHED_FIFO is allowed. With --no-fifo the test runs as a
# process that may not use SCHED_FIFO (CAP_SYS_NICE dropped, RLIMIT_RTPRIO 0), so that the
# fallbacks show on a host that would allow it.
# Usage: package.sh ROSGUARD BUILD_DIR SOURCE_DIR DOMAIN [--no-fifo] TEST_NAME
set -euo pipefail
rosguard=$1 build=$2 src=$3 domain=$4
shift 4
no_fifo=0
if [[ $1 == --no-fifo ]]; then
  no_fifo=1
  shift
fi
name=$1
: "$rosguard"
# shellcheck source=ros2_common.sh
source "$src/tests/ros2/ros2_common.sh"
bin=$build/ros2/install/lib/rosguard_rclcpp/test_rosguard_rclcpp
[[ -x $bin ]] || { echo "FAIL: $bin was not built (Catch2 missing? see $build/ros2/build.log)"; exit 1; }
threads=$src/ros2/rosguard_rclcpp/config/cyclonedds-threads.xml
if ((no_fifo)); then
  if [[ -n $above ]]; then
    # Only a privileged process can make SCHED_FIFO possible again; this one cannot.
    exec prlimit --rtprio=0 -- setpriv --inh-caps=-sys_nice --ambient-caps=-sys_nice \
      --bounding-set=-sys_nice -- "$bin" "$name"
  fi
  exec "$bin" "$name"
fi
[[ -n $above ]] && export CYCLONEDDS_URI="$CYCLONEDDS_URI,file://$threads"
exec "$bin" "$name"

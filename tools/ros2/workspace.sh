#!/usr/bin/env bash
# The ROS 2 side of rosguard's tests: finds a ROS 2 Humble, then builds with colcon against it
# the project's ROS 2 packages (hw/topic/dds/rosguard_msgs, ros2/rosguard_rclcpp, tests/ros2/peer)
# into BUILD/ros2/. rosguard_rclcpp links the regulation engine of this build, installed first
# into BUILD/ros2/rosguard/ (cmake --install: rosguard's CMake package).
# Called by `make test` (make ros2); the tests of `ctest -L ros2` read what it leaves:
#   BUILD/ros2/env.sh    sources the Humble and the packages built here (ROS 2 found)
#   BUILD/ros2/skipped   why there is no ROS 2 for the tests (then the tests say so and skip)
#
# Which ROS 2: the one in the environment when a ROS 2 Humble is sourced (ROS_DISTRO=humble and
# rclcpp on AMENT_PREFIX_PATH, e.g. `source /opt/ros/humble/setup.bash`); otherwise the minimal
# Humble of tools/ros2/humble.sh, built from ../shared/thirdparty/ros2-humble/ (or cached);
# otherwise none. ROSGUARD_ROS2=OFF: none, on purpose.
# Usage: tools/ros2/workspace.sh BUILD_DIR
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../.." && pwd)
build=$(mkdir -p "${1:?usage: workspace.sh BUILD_DIR}" && cd "$1" && pwd)
out=$build/ros2
mkdir -p "$out"
rm -f "$out/env.sh" "$out/skipped"

skip() {
  echo "$1" >"$out/skipped"
  echo "ros2: no ROS 2 for the tests: $1"
  exit 0
}

if [[ ${ROSGUARD_ROS2:-} == OFF ]]; then
  skip "ROSGUARD_ROS2=OFF"
fi
# The prefix on AMENT_PREFIX_PATH that holds rclcpp, and its setup file.
rclcpp_prefix() {
  local p ps
  IFS=: read -ra ps <<<"${AMENT_PREFIX_PATH:-}"
  for p in "${ps[@]}"; do
    [[ -d $p/share/rclcpp ]] && { echo "$p"; return 0; }
  done
  return 1
}
if [[ ${ROS_DISTRO:-} == humble ]] && prefix=$(rclcpp_prefix); then
  humble_setup=$prefix/setup.sh
  [[ -f $humble_setup ]] ||
    skip "the environment's ROS 2 Humble has rclcpp in $prefix but no setup.sh there to source"
  echo "ros2: using the ROS 2 Humble of this environment ($humble_setup)"
elif [[ -n ${ROS_DISTRO:-} && ${ROS_DISTRO:-} != humble ]]; then
  skip "the environment's ROS 2 is '$ROS_DISTRO'; the tests are written for Humble"
else
  rc=0
  "$here/humble.sh" | tee "$out/humble.log" || rc=$?
  humble_setup=$(tail -n 1 "$out/humble.log")
  if ((rc == 3)); then
    skip "no ROS 2 Humble sourced (ROS_DISTRO, AMENT_PREFIX_PATH) and no Humble sources to build one (../shared/thirdparty/ros2-humble, or ROSGUARD_ROS2_SOURCES)"
  fi
  ((rc == 0)) || { echo "ros2: the Humble build failed" >&2; exit 1; }
fi

# Debian's python3 (with ament_package) first, as for the Humble build; the Humble's variables
# only inside the colcon call.
export PATH=/usr/bin:/bin:$PATH
start=$(date +%s)
if ! cmake --install "$build" --prefix "$out/rosguard" >"$out/install.log" 2>&1; then
  cat "$out/install.log" >&2
  echo "ros2: cmake --install of $build into $out/rosguard failed (log: $out/install.log)" >&2
  exit 1
fi
rc=0
(
  set +u  # ROS 2's setup files read unset variables
  # shellcheck source=/dev/null
  source "$humble_setup"
  cd "$out"
  export CMAKE_PREFIX_PATH=$out/rosguard${CMAKE_PREFIX_PATH:+:$CMAKE_PREFIX_PATH}
  colcon --log-base "$out/log" build --merge-install --build-base build --install-base install \
    --base-paths "$repo/hw/topic/dds/rosguard_msgs" "$repo/ros2/rosguard_rclcpp" "$repo/tests/ros2/peer" \
    --event-handlers console_direct- console_start_end+ \
    --cmake-args -DCMAKE_BUILD_TYPE=Release -DBUILD_TESTING=OFF -DPython3_EXECUTABLE=/usr/bin/python3
) >"$out/build.log" 2>&1 || rc=$?
if ((rc != 0)); then
  cat "$out/build.log" >&2
  echo "ros2: colcon could not build rosguard_msgs, rosguard_rclcpp and the test peer against $humble_setup (log: $out/build.log)" >&2
  exit 1
fi
cat >"$out/env.sh" <<EOF
# Written by tools/ros2/workspace.sh: the ROS 2 Humble the tests use and the packages built on it.
if [ ! -f "$humble_setup" ]; then
  echo "FAIL: the ROS 2 Humble this build folder was set up with is gone ($humble_setup): run make ros2" >&2
  return 1
fi
set +u
source "$humble_setup"
source "$out/install/setup.sh"
export RMW_IMPLEMENTATION=rmw_cyclonedds_cpp
EOF
echo "ros2: rosguard_msgs, rosguard_rclcpp and the rclcpp test peer built in $(($(date +%s) - start)) s against $humble_setup"

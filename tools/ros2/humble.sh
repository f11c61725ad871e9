#!/usr/bin/env bash
# Builds a minimal ROS 2 Humble (rclcpp, rmw_cyclonedds_cpp on Debian's Cyclone DDS 0.10,
# std_msgs and what they need) from the source archives in ../shared/thirdparty/ros2-humble/,
# with Debian's ROS 2 tooling (ament, colcon, rosidl's Python), outside the source tree:
#   ${ROSGUARD_CACHE:-${XDG_CACHE_HOME:-~/.cache}/rosguard}/humble-<key>/install/setup.sh
# <key> is a checksum of the archives, of the libyaml_vendor stand-in and of this script, so a
# second run finds the build and takes a second; a change to any of them builds a new one.
# Prints the setup file's path on its last line. The project's tree holds none of ROS 2's code.
#
# Usage: tools/ros2/humble.sh [--sources DIR] [--check]
#   --sources DIR  the archives (default: $ROSGUARD_ROS2_SOURCES, else ../shared/thirdparty/
#                  ros2-humble beside the checkout)
#   --check        build nothing: print the setup file of a finished build and exit 0, or say
#                  what is missing and exit 1
# Exit 3: no archives (nothing to build from). Other non-zero: the build failed (its log named).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../.." && pwd)
sources=${ROSGUARD_ROS2_SOURCES:-$repo/../shared/thirdparty/ros2-humble}
check=0
while (($#)); do
  case $1 in
    --sources) sources=$2; shift 2 ;;
    --check) check=1; shift ;;
    -h | --help) sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    *) echo "humble.sh: unknown argument '$1' (--help)" >&2; exit 2 ;;
  esac
done

# The packages colcon builds, and the ones it must not see: rcl_logging_spdlog needs
# spdlog_vendor, test_msgs needs test_interface_files, neither of which is here (nor needed:
# logging goes to rcl_logging_noop, and no ROS 2 test is built). They are hidden from colcon
# (COLCON_IGNORE): skipped with --packages-skip, they would still be required by rcl.
targets=(rclcpp std_msgs rmw_cyclonedds_cpp rmw_implementation)
hidden=(rcl_logging/rcl_logging_spdlog rcl_interfaces/test_msgs)
cmake_args=(-DBUILD_TESTING=OFF -DTRACETOOLS_DISABLED=ON -DCMAKE_BUILD_TYPE=Release
  -DPython3_EXECUTABLE=/usr/bin/python3 -DRCL_LOGGING_IMPLEMENTATION=rcl_logging_noop)

shopt -s nullglob
archives=("$sources"/*.tar.gz)
if ((${#archives[@]} == 0)); then
  echo "humble.sh: no ROS 2 Humble source archives in $sources" >&2
  exit 3
fi
key=$( {
  (cd "$sources" && sha256sum -- *.tar.gz)
  (cd "$here" && sha256sum humble.sh libyaml_vendor/*)
} | sha256sum | cut -c1-16)
cache=${ROSGUARD_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/rosguard}
dir=$cache/humble-$key
setup=$dir/install/setup.sh

if [[ -f $dir/complete ]]; then
  echo "humble.sh: ROS 2 Humble already built ($(cat "$dir/complete"))"
  echo "$setup"
  exit 0
fi
if ((check)); then
  echo "humble.sh: no finished build of these archives in $dir (run tools/ros2/humble.sh)" >&2
  exit 1
fi

# Debian's ROS 2 tooling (ament, colcon, empy, lark, ...), installed where missing.
ROSGUARD_ROS2=ON "$repo/tools/install-deps.sh"

mkdir -p "$cache"
exec 9>"$cache/humble.lock"
if ! flock -n 9; then
  echo "humble.sh: another build holds $cache/humble.lock; waiting for it"
  flock 9
fi
if [[ -f $dir/complete ]]; then  # built by the one we waited for
  echo "$setup"
  exit 0
fi
# An unfinished build (killed, failed) is started again from nothing: colcon writes absolute
# paths into the install's setup files, so the build cannot go elsewhere and be moved.
rm -rf "$dir"
mkdir -p "$dir/src"
start=$(date +%s)
echo "humble.sh: building ROS 2 Humble from ${#archives[@]} archives in $sources into $dir (some minutes; log: $dir/build.log)"
for a in "${archives[@]}"; do
  # The real libyaml_vendor downloads libyaml at configure time: the stand-in replaces it.
  [[ $(basename "$a") == libyaml_vendor.tar.gz ]] && continue
  tar xzf "$a" -C "$dir/src"
done
cp -r "$here/libyaml_vendor" "$dir/src/"
for h in "${hidden[@]}"; do touch "$dir/src/$h/COLCON_IGNORE"; done

# ament's templates need Debian's python3 (with ament_package), not another one first on PATH
# (a pyenv shim); a Humble already in the environment must not leak into this one.
unset AMENT_PREFIX_PATH CMAKE_PREFIX_PATH COLCON_PREFIX_PATH ROS_DISTRO ROS_VERSION PYTHONPATH
export PATH=/usr/bin:/bin:$PATH
rc=0
(cd "$dir" && colcon --log-base "$dir/log" build --merge-install \
  --base-paths src --build-base build --install-base install \
  --parallel-workers "$(nproc)" --event-handlers console_direct- console_start_end+ \
  --packages-up-to "${targets[@]}" \
  --cmake-args "${cmake_args[@]}") >"$dir/build.log" 2>&1 || rc=$?
grep -E "^(Finished|Failed|Aborted)" "$dir/build.log" | tail -n 3 || true
if ((rc != 0)); then
  echo "humble.sh: the colcon build failed (exit $rc); log: $dir/build.log, per package: $dir/log/latest_build/" >&2
  grep -E "^Failed|Error|error:" "$dir/build.log" | head -n 20 >&2 || true
  exit 1
fi
# The build tree is not needed once installed (some 200 MB); the sources and logs stay.
rm -rf "$dir/build"
secs=$(($(date +%s) - start))
echo "key $key, built $(date -u +%Y-%m-%dT%H:%M:%SZ) in ${secs} s, $(du -sh "$dir/install" | cut -f1) installed" >"$dir/complete"
echo "humble.sh: done in ${secs} s ($(du -sh "$dir/install" | cut -f1) installed)"
echo "$setup"

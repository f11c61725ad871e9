#!/usr/bin/env bash
# Installs the Debian packages rosguard needs, and only those that are missing.
# Called by `make deps` (and so by `make run` / `make test`). One `apt-get update`, then one
# `apt-get install -y`; nothing when everything is present. Needs root or sudo to install.
# ROSGUARD_WITH_SIM=OFF (as `make test-nosim` sets it): without SystemC (libsystemc-dev).
# ROSGUARD_AARCH64=ON (as `make test-aarch64` sets it): also what the aarch64 cross build needs,
# the cross compiler, qemu-user and the arm64 libraries as Debian multiarch packages (adds the
# arm64 architecture to dpkg once, which needs its own `apt-get update`).
# ROSGUARD_ROS2=ON (as tools/ros2/humble.sh sets it): also Debian's ROS 2 tooling, what a build of
# ROS 2 Humble from source needs (ament, colcon and its plugins, rosidl's Python dependencies,
# libyaml for the libyaml_vendor stand-in); ROS 2 itself is not in Debian 12.
set -euo pipefail

packages=(
  cmake g++ make pkg-config
  libeigen3-dev catch2 nlohmann-json3-dev libvalijson-dev libcli11-dev
  libbenchmark-dev
  python3 python3-matplotlib python3-numpy python3-pandas python3-scipy python3-pytest
  linux-perf stress-ng
  cyclonedds-dev cyclonedds-tools
  valgrind
  help2man bash-completion
  slurm-wlm munge
)
[[ "${ROSGUARD_WITH_SIM:-ON}" == OFF ]] || packages+=(libsystemc-dev)
[[ "${ROSGUARD_ROS2:-OFF}" != ON ]] || packages+=(ament-cmake ament-cmake-ros
  python3-ament-package libament-index-cpp-dev colcon python3-colcon-cmake python3-colcon-ros
  python3-empy python3-lark python3-catkin-pkg python3-importlib-metadata libyaml-dev)
# The aarch64 build (cmake/aarch64-linux-gnu.cmake) is without the sim backend; its header-only
# dependencies (nlohmann-json, CLI11, valijson, Catch2) and idlc are the ones above, Cyclone DDS
# is the arm64 package, and its programs run under qemu-user on the arm64 loader, C library and
# C++ runtime (libc6:arm64, libstdc++6:arm64; the cross compiler's own copies are for linking).
aarch64=0
if [[ "${ROSGUARD_AARCH64:-OFF}" == ON ]]; then
  aarch64=1
  packages+=(g++-aarch64-linux-gnu qemu-user ccache
    cyclonedds-dev:arm64 libc6:arm64 libstdc++6:arm64)
fi

# A name without :arch means this machine's architecture (or an Architecture: all package): with
# arm64 added, dpkg-query lists both instances of a multiarch package such as cyclonedds-dev.
native=$(dpkg --print-architecture)
missing=()
for p in "${packages[@]}"; do
  arch=$native
  [[ $p != *:* ]] || arch=${p#*:}
  dpkg-query -W -f='${Architecture} ${Status}\n' "$p" 2>/dev/null |
    grep -Eqx "($arch|all) install ok installed" || missing+=("$p")
done

if ((${#missing[@]} == 0)); then
  echo "deps: all ${#packages[@]} Debian packages present"
  exit 0
fi

echo "deps: installing missing Debian packages: ${missing[*]}"
add_arch=0
if ((aarch64)) && ! dpkg --print-foreign-architectures | grep -qx arm64; then
  add_arch=1
fi
if [[ $(id -u) -eq 0 ]]; then
  sudo=()
elif command -v sudo >/dev/null 2>&1; then
  sudo=(sudo)
else
  echo "deps: not root and no sudo; install them yourself:" >&2
  ((add_arch == 0)) || echo "  dpkg --add-architecture arm64" >&2
  echo "  apt-get update && apt-get install -y ${missing[*]}" >&2
  exit 1
fi
if ((add_arch)); then
  "${sudo[@]}" dpkg --add-architecture arm64
  unset ROSGUARD_APT_UPDATED  # the lists have no arm64 packages yet
fi
export DEBIAN_FRONTEND=noninteractive
# slurm-wlm and munge are for tests/slurm, which start their own daemons on their own config;
# their packages' postinst would start the system's (invoke-rc.d). Under systemd that is what
# Debian intends (munge starts; slurmd / slurmctld skip without /etc/slurm/slurm.conf). In a
# container or chroot without systemd (CI) nothing must start: a policy-rc.d that refuses every
# start (Debian's mechanism for image builds) is put in place for this install, where none is.
policy=/usr/sbin/policy-rc.d
if [[ ! -d /run/systemd/system && ! -e $policy ]]; then
  "${sudo[@]}" sh -c "printf '#!/bin/sh\nexit 101\n' >$policy && chmod 755 $policy"
  trap '"${sudo[@]}" rm -f "$policy"' EXIT
fi
# ROSGUARD_APT_UPDATED: the caller (e.g. .ci/run) has just updated the package lists.
[[ -n "${ROSGUARD_APT_UPDATED:-}" ]] || "${sudo[@]}" apt-get update
"${sudo[@]}" apt-get install -y --no-install-recommends "${missing[@]}"

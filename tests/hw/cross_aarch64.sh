#!/usr/bin/env bash
# Builds the hw event table for aarch64 and runs it under qemu-user: the names must map to the
# ARMv8 PMUv3 raw codes (type PERF_TYPE_RAW = 4) when compiled for that architecture. Also checks
# that the whole hw/ library compiles for aarch64. Skips (exit 0, with a reason) without the
# Debian packages g++-aarch64-linux-gnu and qemu-user.
set -euo pipefail
src=${1:?source dir}
if ! command -v aarch64-linux-gnu-g++ >/dev/null || ! command -v qemu-aarch64 >/dev/null; then
  echo "SKIPPED: needs aarch64-linux-gnu-g++ and qemu-aarch64 (apt-get install g++-aarch64-linux-gnu qemu-user)"
  exit 0
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cat > "$tmp/t.cpp" <<'CPP'
#include <cstdio>
#include "hw/pmc_source/perf_events.h"
using namespace rosguard::hw;
int main() {
  std::printf("%s\n", std::string(to_string(host_arch())).c_str());
  for (const auto& n : hardware_event_names()) {
    auto e = hardware_event(n, host_arch());
    std::printf("%s %u 0x%llx\n", n.c_str(), e->type, static_cast<unsigned long long>(e->config));
  }
}
CPP
aarch64-linux-gnu-g++ -std=c++20 -O2 -static -I"$src" -I"$src/model" "$tmp/t.cpp" \
  "$src/hw/pmc_source/perf_events.cpp" -o "$tmp/t"
out=$(qemu-aarch64 "$tmp/t")
expected="aarch64
cpu_cycles 4 0x11
inst_retired 4 0x8
l2d_cache_refill 4 0x17
l2d_cache_wb 4 0x18
l3d_cache 4 0x2b
l3d_cache_refill 4 0x2a"
if [[ "$out" != "$expected" ]]; then
  echo "FAIL: aarch64 event table:"; echo "$out"; exit 1
fi
for f in "$src"/hw/*.cpp "$src"/hw/*/*.cpp; do
  aarch64-linux-gnu-g++ -std=c++20 -O2 -Wall -Wextra -Werror -c -I"$src" -I"$src/model" "$f" \
    -o "$tmp/$(basename "$f").o"
done
echo "aarch64: event table gives the PMUv3 raw codes under qemu; hw/ compiles for aarch64"

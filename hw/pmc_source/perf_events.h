// The named-event table: rosguard event names -> perf_event_attr (type, config) per architecture.
//
// Contract: pure lookups, no system calls; usable from tests on any host for any architecture.
// Hardware names follow ARMv8 PMUv3 (lower case): on aarch64 they are raw PMU event numbers; on
// x86-64 they map to the nearest generic perf events (noted per entry), since x86 has no common
// raw encoding for L2 refills / write-backs.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace rosguard::hw {

enum class Arch { Aarch64, X86_64, Other };

Arch host_arch();
std::string_view to_string(Arch a);

struct PerfEventCode {
  std::uint32_t type = 0;    // PERF_TYPE_*
  std::uint64_t config = 0;  // raw event number or generic id
  std::string_view note;     // what it counts on this architecture
};

// The hardware events rosguard names: cpu_cycles, inst_retired, l2d_cache_refill, l2d_cache_wb,
// l3d_cache, l3d_cache_refill.
const std::vector<std::string>& hardware_event_names();
std::optional<PerfEventCode> hardware_event(std::string_view name, Arch arch);

// Software events: task_clock, cpu_clock, context_switches, cpu_migrations, page_faults.
const std::vector<std::string>& software_event_names();
std::optional<PerfEventCode> software_event(std::string_view name);

}  // namespace rosguard::hw

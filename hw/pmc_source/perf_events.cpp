#include "hw/pmc_source/perf_events.h"

#include <linux/perf_event.h>

namespace rosguard::hw {

Arch host_arch() {
#if defined(__aarch64__)
  return Arch::Aarch64;
#elif defined(__x86_64__)
  return Arch::X86_64;
#else
  return Arch::Other;
#endif
}

std::string_view to_string(Arch a) {
  switch (a) {
    case Arch::Aarch64:
      return "aarch64";
    case Arch::X86_64:
      return "x86_64";
    case Arch::Other:
      return "other";
  }
  return "?";
}

const std::vector<std::string>& hardware_event_names() {
  static const std::vector<std::string> names = {"cpu_cycles",       "inst_retired",
                                                 "l2d_cache_refill", "l2d_cache_wb",
                                                 "l3d_cache",        "l3d_cache_refill"};
  return names;
}

namespace {

constexpr std::uint64_t hw_cache(std::uint64_t cache, std::uint64_t op, std::uint64_t result) {
  return cache | (op << 8) | (result << 16);
}

}  // namespace

std::optional<PerfEventCode> hardware_event(std::string_view name, Arch arch) {
  if (arch == Arch::Aarch64) {
    // ARMv8 PMUv3 common event numbers (Arm ARM D7.10, Cortex-A78AE TRM).
    if (name == "cpu_cycles") return PerfEventCode{PERF_TYPE_RAW, 0x11, "CPU_CYCLES"};
    if (name == "inst_retired") return PerfEventCode{PERF_TYPE_RAW, 0x08, "INST_RETIRED"};
    if (name == "l2d_cache_refill") return PerfEventCode{PERF_TYPE_RAW, 0x17, "L2D_CACHE_REFILL"};
    if (name == "l2d_cache_wb") return PerfEventCode{PERF_TYPE_RAW, 0x18, "L2D_CACHE_WB"};
    if (name == "l3d_cache") return PerfEventCode{PERF_TYPE_RAW, 0x2B, "L3D_CACHE"};
    if (name == "l3d_cache_refill") return PerfEventCode{PERF_TYPE_RAW, 0x2A, "L3D_CACHE_REFILL"};
    return std::nullopt;
  }
  if (arch == Arch::X86_64) {
    if (name == "cpu_cycles")
      return PerfEventCode{PERF_TYPE_HARDWARE, PERF_COUNT_HW_CPU_CYCLES, "generic cpu-cycles"};
    if (name == "inst_retired")
      return PerfEventCode{PERF_TYPE_HARDWARE, PERF_COUNT_HW_INSTRUCTIONS, "generic instructions"};
    // The LLC of x86 parts sits behind the L2: an LLC reference is an L2 miss (refill) and an
    // LLC write access is (mostly) an L2 write-back.
    if (name == "l2d_cache_refill")
      return PerfEventCode{PERF_TYPE_HARDWARE, PERF_COUNT_HW_CACHE_REFERENCES,
                           "generic cache-references (LLC accesses = L2 misses)"};
    if (name == "l2d_cache_wb")
      return PerfEventCode{PERF_TYPE_HW_CACHE,
                           hw_cache(PERF_COUNT_HW_CACHE_LL, PERF_COUNT_HW_CACHE_OP_WRITE,
                                    PERF_COUNT_HW_CACHE_RESULT_ACCESS),
                           "LLC write accesses (L2 write-backs)"};
    if (name == "l3d_cache")
      return PerfEventCode{PERF_TYPE_HW_CACHE,
                           hw_cache(PERF_COUNT_HW_CACHE_LL, PERF_COUNT_HW_CACHE_OP_READ,
                                    PERF_COUNT_HW_CACHE_RESULT_ACCESS),
                           "LLC read accesses"};
    if (name == "l3d_cache_refill")
      return PerfEventCode{PERF_TYPE_HARDWARE, PERF_COUNT_HW_CACHE_MISSES,
                           "generic cache-misses (LLC misses)"};
    return std::nullopt;
  }
  // Elsewhere only the architecture-neutral generic events.
  if (name == "cpu_cycles")
    return PerfEventCode{PERF_TYPE_HARDWARE, PERF_COUNT_HW_CPU_CYCLES, "generic cpu-cycles"};
  if (name == "inst_retired")
    return PerfEventCode{PERF_TYPE_HARDWARE, PERF_COUNT_HW_INSTRUCTIONS, "generic instructions"};
  return std::nullopt;
}

const std::vector<std::string>& software_event_names() {
  static const std::vector<std::string> names = {"task_clock", "cpu_clock", "context_switches",
                                                 "cpu_migrations", "page_faults"};
  return names;
}

std::optional<PerfEventCode> software_event(std::string_view name) {
  if (name == "task_clock")
    return PerfEventCode{PERF_TYPE_SOFTWARE, PERF_COUNT_SW_TASK_CLOCK, "task clock, ns on cpu"};
  if (name == "cpu_clock")
    return PerfEventCode{PERF_TYPE_SOFTWARE, PERF_COUNT_SW_CPU_CLOCK, "cpu clock, ns"};
  if (name == "context_switches")
    return PerfEventCode{PERF_TYPE_SOFTWARE, PERF_COUNT_SW_CONTEXT_SWITCHES, "context switches"};
  if (name == "cpu_migrations")
    return PerfEventCode{PERF_TYPE_SOFTWARE, PERF_COUNT_SW_CPU_MIGRATIONS, "cpu migrations"};
  if (name == "page_faults")
    return PerfEventCode{PERF_TYPE_SOFTWARE, PERF_COUNT_SW_PAGE_FAULTS, "page faults"};
  return std::nullopt;
}

}  // namespace rosguard::hw

// A core's PMU: cumulative event counts, as the regulator reads them on the board.
//
// Contract: pure C++. The core accumulates fractional counts (rates times time); a read returns
// whole counts (floor), never decreasing. Every event counts all the time (no multiplexing), so
// time_enabled == time_running == the read time.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string_view>

#include "core/types.h"
#include "metric/metric.h"

namespace rosguard::sim {

enum class PmuEvent : std::uint8_t {
  CpuCycles,    // cpu_cycles (0x11): every cycle the core executes (not in idle / WFI)
  InstRetired,  // inst_retired (0x08)
  L2Refill,     // l2d_cache_refill (0x17): L2 misses, i.e. L3 reads
  L2Wb,         // l2d_cache_wb (0x18): L2 write-backs, i.e. L3 writes
  L3Access,     // l3d_cache (0x2B): refills + write-backs reaching the L3
  L3Refill,     // l3d_cache_refill (0x2A): L2 refills that miss in the L3 (DRAM reads)
};
inline constexpr std::size_t kPmuEvents = 6;

std::optional<PmuEvent> pmu_event(std::string_view name);

struct Pmu {
  std::array<double, kPmuEvents> count{};

  double operator[](PmuEvent e) const { return count[static_cast<std::size_t>(e)]; }
  double& operator[](PmuEvent e) { return count[static_cast<std::size_t>(e)]; }
  std::uint64_t value(PmuEvent e) const {
    return static_cast<std::uint64_t>(std::floor((*this)[e]));
  }
  CounterValue read(PmuEvent e, TimeNs now) const {
    const auto t = static_cast<std::uint64_t>(now);
    return {value(e), t, t};
  }
  // L3 accesses (the Eq. 1 numerator): refills + write-backs.
  double l3_accesses() const { return (*this)[PmuEvent::L2Refill] + (*this)[PmuEvent::L2Wb]; }
};

}  // namespace rosguard::sim

#include "platform/pmu.h"

namespace rosguard::sim {

std::optional<PmuEvent> pmu_event(std::string_view name) {
  if (name == "cpu_cycles") return PmuEvent::CpuCycles;
  if (name == "inst_retired") return PmuEvent::InstRetired;
  if (name == "l2d_cache_refill") return PmuEvent::L2Refill;
  if (name == "l2d_cache_wb") return PmuEvent::L2Wb;
  if (name == "l3d_cache") return PmuEvent::L3Access;
  if (name == "l3d_cache_refill") return PmuEvent::L3Refill;
  return std::nullopt;
}

}  // namespace rosguard::sim

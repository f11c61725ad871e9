// What a simulation records for its report: observations for samples.csv, regulation windows,
// the intervals regulation was active, and trace events.
//
// Contract: owned by the System of one simulation; components append to it from SystemC
// processes. Plain data, no SystemC.
#pragma once

#include <string_view>
#include <vector>

#include "backend/backend.h"
#include "backend/trace.h"
#include "core/types.h"

namespace rosguard::sim {

// Traffic of one regulated entity in one regulation window (exact, from its PMU).
struct WindowUsage {
  std::size_t entity = 0;
  std::size_t index = 0;  // window number since the activation began
  TimeNs start = 0;
  TimeNs end = 0;
  double bytes = 0.0;
  bool complete = true;  // false: cut short by the end of the activation
};

struct Recorder {
  TraceSink* trace = nullptr;
  std::vector<Observation> samples;
  std::vector<WindowUsage> windows;

  void observe(std::string_view kind, TimeNs duration_ns) {
    samples.push_back({std::string(kind), static_cast<double>(duration_ns) / 1e3});
  }
};

}  // namespace rosguard::sim

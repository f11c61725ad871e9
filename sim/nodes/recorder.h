// What a simulation records for its report: observations for samples.csv and trace events.
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

struct Recorder {
  TraceSink* trace = nullptr;
  std::vector<Observation> samples;

  void observe(std::string_view kind, TimeNs duration_ns) {
    samples.push_back({std::string(kind), static_cast<double>(duration_ns) / 1e3});
  }
};

}  // namespace rosguard::sim

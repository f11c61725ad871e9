// Trace events a backend emits when --trace is on (written as Chrome trace JSON by the runner).
//
// Contract: called from the thread that runs the task; times are the backend's own clock in ns
// from the start of the task (simulated time in sim, monotonic time in hw). `track` names a row
// in the viewer ("nrt0 state", "rt0"); `core` groups rows per core.
#pragma once

#include <string_view>

#include "core/types.h"

namespace rosguard {

class TraceSink {
 public:
  virtual ~TraceSink() = default;
  // Something that lasted [begin, end): a node state (OFF / ON / THR), an RT job, a callback.
  virtual void span(TimeNs begin, TimeNs end, int core, std::string_view track,
                    std::string_view name) = 0;
  // A value over time: the per-core bandwidth counter, a budget account.
  virtual void counter(TimeNs t, int core, std::string_view name, double value) = 0;
  // A moment: a command sent or received, a threshold crossed.
  virtual void instant(TimeNs t, int core, std::string_view track, std::string_view name) = 0;
};

}  // namespace rosguard

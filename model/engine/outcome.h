// One way to build a point's outcome (model/backend/backend.h) from what the drivers and the
// host accounted, used by both backends.
//
// Contract: pure functions. "Not applicable" (nothing was measured: no RT job finished, no run
// completed in the window, no traffic window) is NaN in the outcome, which results.csv writes
// as an empty cell; a zero is a measured zero.
#pragma once

#include <optional>
#include <span>
#include <string>

#include "backend/backend.h"
#include "engine/controller_driver.h"
#include "engine/nrt_driver.h"

namespace rosguard {

// The value meaning "not applicable" in an outcome.
double not_applicable();

// An RT node's outcome from its finished jobs, in job order: durations (start to finish) and
// response times (release to finish) in ns; `period_ns` when the node has a period (its implicit
// deadline, against which misses are counted).
RtOutcome rt_outcome(const std::string& name, std::span<const double> job_ns,
                     std::span<const double> response_ns, std::optional<double> period_ns);

// What the host measured of one nRT node besides the driver's bookkeeping.
struct NrtMeasure {
  std::string name;
  bool once = false;
  std::optional<double> once_ns;  // once: how long its one run took, when it finished
  double runs = 0.0;              // runs completed in `window_ns` (once: the fraction done)
  TimeNs window_ns = 0;           // loop: the window the runs were counted in
  EntityReading traffic;          // bytes (and cycles, if counted) over `traffic_ns`
  TimeNs traffic_ns = 0;          // the bandwidth window (regulation active)
  double freq_hz = 0.0;           // core frequency for Eq. 1 when cycles were counted
};

NrtOutcome nrt_outcome(const NrtMeasure& measure, const NrtDriver& driver);

}  // namespace rosguard

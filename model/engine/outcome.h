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
#include <vector>

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

// How one run of an nRT workload progresses in isolation: after `work[k]` units of work (the
// sim: instructions; hw built-in kernels: runs, the work being uniform) the run has taken
// `time[k]` of its isolation time (any unit: only shares of the run's total are used), linear in
// between. Both increase; the last entries are one whole run. A loop node's work counts over its
// runs one after the other: cumulative work w is w mod work_per_run() into run
// floor(w / work_per_run()).
struct IsolationProgress {
  std::vector<double> work;
  std::vector<double> time;

  // Uniform work: `per_run` units, each taking the same time.
  static IsolationProgress uniform(double per_run) { return {{per_run}, {1.0}}; }
  double work_per_run() const { return work.empty() ? 0.0 : work.back(); }
  // Isolation time from the start of the first run to cumulative work `w`, in runs.
  double runs_at(double w) const;
  // The work between cumulative work `from` and `to` (from <= to) expressed as isolation runs:
  // the isolation time of exactly that work range over the isolation time of one run. Uniform
  // work: (to - from) / work_per_run().
  double isolation_runs(double from, double to) const;
};

// What the host measured of one nRT node besides the driver's bookkeeping.
//
// The loop-mode rule (both backends): the nRT time compares the same work. A loop node did the
// work from cumulative `work_from` to `work_to` (units of `progress`) inside the window; its
// time is window_ns / progress.isolation_runs(work_from, work_to), so that its slowdown against
// the isolation time of one run is the window over the time isolation takes for exactly that
// work, wherever the window falls among the workload's phases.
struct NrtMeasure {
  std::string name;
  bool once = false;
  std::optional<double> once_ns;  // once: how long its one run took, when it finished
  double runs = 0.0;              // once: the fraction of its run done (loop: ignored)
  TimeNs window_ns = 0;           // loop: the window the work was counted in
  double work_from = 0.0;         // loop: cumulative work when the window opened
  double work_to = 0.0;           // loop: cumulative work when it closed (summed over windows)
  IsolationProgress progress = IsolationProgress::uniform(1.0);  // loop: see above
  EntityReading traffic;  // bytes (and cycles, if counted) over `traffic_ns`
  TimeNs traffic_ns = 0;  // the bandwidth window (regulation active)
  double freq_hz = 0.0;   // core frequency for Eq. 1 when cycles were counted
};

NrtOutcome nrt_outcome(const NrtMeasure& measure, const NrtDriver& driver);

}  // namespace rosguard

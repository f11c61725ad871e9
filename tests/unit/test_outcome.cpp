// The shared outcome code (model/engine/outcome.h): the loop-mode nRT time compares the same
// work as the isolation run, weighed by the isolation progress of the workload's phases.
#include <catch2/catch.hpp>
#include <cmath>

#include "core/error.h"
#include "engine/outcome.h"

using namespace rosguard;

namespace {

// Two phases of 100 instructions each: the first takes 3 time units, the second 1.
IsolationProgress two_phases() {
  return {{100.0, 200.0}, {3.0, 4.0}};
}

NrtMeasure loop_measure(double from, double to, TimeNs window_ns, IsolationProgress p) {
  NrtMeasure m;
  m.name = "nrt0";
  m.window_ns = window_ns;
  m.work_from = from;
  m.work_to = to;
  m.progress = std::move(p);
  return m;
}

}  // namespace

TEST_CASE("isolation progress: the isolation time of a work range, phase by phase",
          "[engine][outcome]") {
  const IsolationProgress p = two_phases();
  CHECK(p.work_per_run() == 200.0);
  CHECK(p.runs_at(0.0) == 0.0);
  CHECK(p.runs_at(50.0) == Approx(1.5 / 4.0));
  CHECK(p.runs_at(100.0) == Approx(3.0 / 4.0));
  CHECK(p.runs_at(150.0) == Approx(3.5 / 4.0));
  CHECK(p.runs_at(200.0) == Approx(1.0));
  // Work counts over the runs one after the other.
  CHECK(p.runs_at(450.0) == Approx(2.0 + 1.5 / 4.0));
  // A range inside the slow phase is worth more isolation time than its share of the work.
  CHECK(p.isolation_runs(0.0, 100.0) == Approx(0.75));
  CHECK(p.isolation_runs(100.0, 200.0) == Approx(0.25));
  // Across a run boundary: the second phase of run 0 and the first of run 1.
  CHECK(p.isolation_runs(100.0, 300.0) == Approx(1.0));
  CHECK(p.isolation_runs(150.0, 250.0) == Approx(0.125 + 0.375));
  // Uniform work: the share of the work.
  CHECK(IsolationProgress::uniform(8.0).isolation_runs(2.0, 14.0) == Approx(1.5));
  CHECK_THROWS_AS(p.isolation_runs(2.0, 1.0), ContractError);
  CHECK_THROWS_AS((IsolationProgress{}).runs_at(1.0), ContractError);
}

TEST_CASE("loop nRT time: the window over the isolation runs of exactly the work done in it",
          "[engine][outcome]") {
  const NrtDriver driver(Sampling::Self);
  // One run takes 4 ms in isolation (3 ms for the first 100 instructions, 1 ms for the next).
  // A window of 3 ms in which the node did the first phase: no slowdown, a time of 4 ms per
  // run, where counting work alone (half a run in 3 ms) would say 6 ms.
  const NrtOutcome slow = nrt_outcome(loop_measure(0.0, 100.0, 3'000'000, two_phases()), driver);
  CHECK(slow.time_us == Approx(4000.0));
  CHECK(slow.runs == Approx(0.5));
  // The same 3 ms over the second phase at a third of its isolation speed: slowdown 3.
  const NrtOutcome fast = nrt_outcome(loop_measure(100.0, 200.0, 3'000'000, two_phases()), driver);
  CHECK(fast.time_us == Approx(12000.0));
  // Nothing done, or no window: not applicable.
  CHECK(std::isnan(nrt_outcome(loop_measure(5.0, 5.0, 3'000'000, two_phases()), driver).time_us));
  CHECK(std::isnan(nrt_outcome(loop_measure(0.0, 100.0, 0, two_phases()), driver).time_us));
  // once: the measured run, untouched by the progress.
  NrtMeasure once;
  once.once = true;
  once.runs = 1.0;
  once.once_ns = 2'500'000.0;
  CHECK(nrt_outcome(once, driver).time_us == Approx(2500.0));
}

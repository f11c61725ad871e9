// The sim backend: runs scenario points on the SystemC model of the Orin CPU complex.
//
// Contract: process_per_task() is true: the runner calls isolation() and run_point() in a fresh
// worker process each (SystemC elaborates once per process). validate() creates no SystemC
// object, so the runner may call it in its own process for every point.
#pragma once

#include "backend/backend.h"
#include "system.h"

namespace rosguard::sim {

class SimBackend : public Backend {
 public:
  // `policies` (the run's registry, filled in main) must outlive the backend.
  explicit SimBackend(const PolicyRegistry& policies) : policies_(policies) {}
  std::string_view name() const override { return "sim"; }
  bool process_per_task() const override { return true; }
  // The model is deterministic: a second measurement would give the same figures.
  int baseline_repetitions(const Scenario&) const override { return 1; }
  void validate(const Scenario& point) const override;
  IsolationResult isolation(const Scenario& scenario, const WorkloadInfo& workload, int core,
                            std::uint64_t seed, RunContext& ctx) override;
  PointOutcome run_point(const Scenario& point, const Baselines& baselines, int rep,
                         std::uint64_t seed, RunContext& ctx) override;

 private:
  const PolicyRegistry& policies_;
};

// The simulation a point describes, regulated by `regulation` (regulation_setup() of the point;
// used by run_point, and by tests that need the full report).
RunConfig point_config(const Scenario& point, RegulationSetup regulation, std::uint64_t seed);
// The isolation run of `workload` on `core` under `scenario`'s platform and settings.
RunConfig isolation_config(const Scenario& scenario, const WorkloadInfo& workload, int core,
                           std::uint64_t seed);

}  // namespace rosguard::sim

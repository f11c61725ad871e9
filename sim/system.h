// One simulation of the Orin model: elaborate the platform and the nodes, run, report.
//
// Contract: simulate() elaborates SystemC, which can happen once per process (the runner forks a
// worker per task; tests run each elaborating case in its own process). A second call in the
// same process throws RunError. Everything random comes from RunConfig::seed; the same config
// gives the same report, bit for bit.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "backend/backend.h"
#include "engine/controller_driver.h"
#include "nodes/recorder.h"
#include "nodes/rt_node.h"
#include "platform/sim_platform.h"
#include "regulator/setup.h"
#include "workload/profile.h"

namespace rosguard::sim {

struct RtSpec {
  std::string name;
  int core = 0;
  WorkloadProfile profile;
  int iterations = 1;
  std::optional<TimeNs> period_ns;
};

struct NrtSpec {
  std::string name;
  int core = 0;
  WorkloadProfile profile;
  bool loop = true;
};

// The simulated time one run may take by default (RunConfig::limit_ns).
inline constexpr TimeNs kRunLimitNs = 600LL * kNsPerS;

struct RunConfig {
  SimPlatform platform;
  TimeNs quantum_ns = 10'000;
  std::uint64_t seed = 1;
  int controller_core = 0;
  std::vector<RtSpec> rt;
  std::vector<NrtSpec> nrt;
  // Isolation: the first RT node alone, no controller and no regulation.
  bool isolation = false;
  // The regulation (regulator/setup.h; point_config). Isolation: only its metric, what the
  // cores count.
  RegulationSetup regulation;
  TraceSink* trace = nullptr;
  std::function<bool()> stop_requested;  // polled every few ms of simulated time
  TimeNs limit_ns = kRunLimitNs;         // simulated time after which the run is a failure
};

struct SimReport {
  PointOutcome outcome;
  std::vector<std::vector<JobStats>> rt_jobs;  // per RT node
  std::vector<WindowUsage> windows;            // per regulation window and nRT node
  TimeNs end_ns = 0;                           // simulated time at the end
  std::uint64_t activations = 0;               // SystemC process activations of the model
  std::uint64_t memory_solves = 0;             // fixed points computed (others memoised)
};

SimReport simulate(const RunConfig& config);

// The SystemC library's version ("2.3.4-Accellera"), for the manifest.
std::string sc_version_string();

// The unregulated isolation figures (Table 1 quantities) of an isolation report's one job.
IsolationResult isolation_of(const SimReport& report, const SimPlatform& platform);

}  // namespace rosguard::sim

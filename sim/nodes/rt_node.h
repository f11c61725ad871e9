// An RT (critical) node on its core: runs `iterations` jobs of its workload, back to back or
// released every period. At each job's start it publishes the enable signal to the controller,
// at its end the disable signal (message_latency_us each; the signals cost the RT core nothing).
//
// Contract: a SystemC module created during elaboration; start() at time 0.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <systemc>
#include <vector>

#include "kernel/runtime.h"
#include "nodes/costs.h"
#include "nodes/recorder.h"
#include "platform/core.h"

namespace rosguard::sim {

class Controller;

struct RtNodeConfig {
  std::size_t index = 0;
  std::string name;
  int iterations = 1;
  std::optional<TimeNs> period_ns;
};

// One job: its times and its core's PMU deltas (the isolation figures come from these).
struct JobStats {
  TimeNs release = 0;  // its period's start (no period: its start)
  TimeNs start = 0;
  TimeNs end = 0;
  double cycles = 0.0;
  double instructions = 0.0;
  double l3_accesses = 0.0;
};

class RtNodeModel : public sc_core::sc_module {
 public:
  RtNodeModel(const sc_core::sc_module_name& name, RtNodeConfig config,
              const WorkloadProfile& profile, const CostParams& costs, std::uint64_t seed,
              Core& core, MessageBus& bus, Controller* controller, Runtime& rt, Recorder& rec);

  void start(TimeNs now);
  void on_job_start(std::function<void(TimeNs)> fn) { on_job_start_ = std::move(fn); }
  void on_done(std::function<void(TimeNs)> fn) { on_done_ = std::move(fn); }

  const std::vector<JobStats>& jobs() const { return jobs_; }
  bool done() const { return done_; }
  const RtNodeConfig& config() const { return cfg_; }

 private:
  void release(TimeNs now);
  void begin_job(TimeNs now);
  void job_done(TimeNs now);

  RtNodeConfig cfg_;
  Core& core_;
  MessageBus& bus_;
  Controller* controller_;  // null in isolation runs
  Runtime& rt_;
  Recorder& rec_;
  CostStream latency_;
  int link_;
  WorkloadRun run_;
  Timer release_timer_;
  int next_job_ = 0;
  bool running_ = false;
  JobStats current_;
  Pmu start_pmu_;
  std::vector<JobStats> jobs_;
  bool done_ = false;
  std::function<void(TimeNs)> on_job_start_, on_done_;
};

}  // namespace rosguard::sim

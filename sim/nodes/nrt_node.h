// An nRT node on its core: the nominal application (NCT) at the lowest priority, and the
// ROSGuard callbacks around it. The nRT engine (model/engine/nrt_driver.h) decides the state
// transitions, their side effects and the throttle bookkeeping; this module adds their costs.
//
//   CFB  every command received costs throttle_activation_us at the highest priority; at its end
//        the command takes effect: THR enters the idle loop (the zero-time timer fired), ON starts
//        self-sampling, REPLENISH leaves the loop, OFF returns to nominal.
//   PMC  self-sampling only, in state ON: at ON and then every sampling period, the PMC callback
//        (pmc_callback_us) reads the counters and publishes them; the middleware then works for
//        publish_us on this core before the message leaves for the controller. A period that
//        expires while the previous sample is still being handled, or while throttled, runs
//        once as soon as possible (ROS 2 timer semantics).
//   NCT  the workload: `loop` restarts it until the RT nodes finish; `once` runs it one time.
//
// Observations: pmc_callback (each PMC callback), sampling_overhead (time the core lost to each
// sample: callback + publishing), activation_delay (from publishing, or the controller's read of,
// the threshold-exceeding sample to entering THR).
//
// Contract: a SystemC module created during elaboration; inputs come from SystemC processes.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <systemc>
#include <vector>

#include "engine/nrt_driver.h"
#include "kernel/runtime.h"
#include "nodes/costs.h"
#include "nodes/recorder.h"
#include "platform/core.h"

namespace rosguard::sim {

class Controller;

struct NrtNodeConfig {
  std::size_t entity = 0;
  std::string name;
  bool loop = true;
  Sampling sampling = Sampling::Self;
  TimeNs sampling_period_ns = 1'000'000;
  std::vector<PmuEvent> metric_events;
  std::uint32_t line_bytes = 64;
  double freq_hz = 1e9;
};

class NrtNodeModel : public sc_core::sc_module {
 public:
  NrtNodeModel(const sc_core::sc_module_name& name, NrtNodeConfig config,
               const WorkloadProfile& profile, const CostParams& costs, std::uint64_t seed,
               Core& core, MessageBus& bus, Controller& controller, Runtime& rt, Recorder& rec);

  void start(TimeNs now);
  // A command message from the controller arrived (now); `origin` is when the sample that caused
  // it was published / read (THR), or -1.
  void on_command(Command command, TimeNs origin);
  // Called once when a `once` run completes.
  void on_done(std::function<void(TimeNs)> fn) { on_done_ = std::move(fn); }

  Core& core() { return core_; }
  const NrtNodeConfig& config() const { return cfg_; }
  const WorkloadProfile& profile() const { return profile_; }
  bool done() const { return done_; }
  TimeNs finished_at() const { return finished_at_; }
  const NrtDriver& driver() const { return driver_; }
  double retired() { return core_.work_retired(); }
  // End of the simulation: closes the open state span and THR interval.
  void finish(TimeNs now);

 private:
  void pmc_timer(TimeNs now);
  void post_pmc(bool timer = false);  // timer: woken by the sampling timer
  void pmc_done(TimeNs cost, TimeNs now);
  void apply(Command command, TimeNs origin, TimeNs now);
  void set_state_span(NodeState from, TimeNs now);
  void work_ended(TimeNs now);

  NrtNodeConfig cfg_;
  const WorkloadProfile& profile_;
  Core& core_;
  MessageBus& bus_;
  Controller& controller_;
  Runtime& rt_;
  Recorder& rec_;
  CostStream pmc_cost_;
  CostStream publish_cost_;
  CostStream cfb_cost_;
  std::optional<CostStream> wakeup_cost_;  // timer_wakeup_us: before a timer-driven sample
  CostStream latency_;
  // The platform's local_message_latency_us applies (the controller beside this node): measured
  // from the publish call's start, as the controller preempts the publisher inside it.
  bool local_message_ = false;
  int link_;

  NrtDriver driver_;
  SampleSchedule schedule_;
  WorkloadRun run_;
  Timer sample_timer_;
  bool sample_busy_ = false;  // a PMC callback or its publishing is under way
  TimeNs state_since_ = 0;
  TimeNs thr_since_ = -1;  // for the trace
  bool done_ = false;
  TimeNs finished_at_ = -1;
  std::function<void(TimeNs)> on_done_;
  std::string state_track_;
  // Bandwidth counter of the trace: the PMU at the previous sample.
  bool have_last_ = false;
  double last_l3_ = 0.0, last_cycles_ = 0.0;
  double freq_hz_ = 1e9;
};

}  // namespace rosguard::sim

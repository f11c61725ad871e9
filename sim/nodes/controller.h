// The controller node: hosts the shared regulator core (model/regulator) on its dedicated core.
//
// It serves one callback at a time, first come first served: RT enable / disable signals, samples
// published by nRT nodes (self-sampling), reads of the nRT cores' counters (external sampling,
// every sampling period from the activation on), and the regulation-period timer. Each callback
// costs controller_callback_us (plus external_read_us for a read); the regulator is called at the
// callback's end with that time, and the commands it returns are published then and reach the
// nRT node message_latency_us later.
//
// Contract: a SystemC module; wired by the System before the simulation starts (add_nrt()).
// Inputs are called from SystemC processes at the current time.
#pragma once

#include <deque>
#include <functional>
#include <memory>
#include <systemc>
#include <vector>

#include "kernel/runtime.h"
#include "nodes/costs.h"
#include "nodes/recorder.h"
#include "platform/pmu.h"
#include "regulator/regulator.h"

namespace rosguard::sim {

class NrtNodeModel;

struct ControllerConfig {
  int core = 0;
  Sampling sampling = Sampling::Self;
  TimeNs sampling_period_ns = 1'000'000;
  TimeNs regulation_period_ns = 5'000'000;  // window probes (interval / monitor)
  bool periodic_windows = false;
  std::uint32_t line_bytes = 64;
  std::vector<PmuEvent> metric_events;
};

class Controller : public sc_core::sc_module {
 public:
  Controller(const sc_core::sc_module_name& name, ControllerConfig config,
             std::unique_ptr<Regulator> regulator, const CostParams& costs, std::uint64_t seed,
             MessageBus& bus, Runtime& rt, Recorder& rec);

  // Wiring (elaboration): the regulated nRT nodes in entity order.
  void add_nrt(NrtNodeModel* node);
  // Called whenever regulation stops (an activation ended).
  void on_inactive(std::function<void(TimeNs)> fn) { on_inactive_ = std::move(fn); }

  // Inputs (messages delivered, or direct calls for the virtual RT node of an RT-less scenario).
  void enable(std::size_t rt, TimeNs now);
  void disable(std::size_t rt, TimeNs now);
  void sample(std::size_t entity, std::vector<CounterValue> counters, TimeNs published, TimeNs now);

  const Regulator& regulator() const { return *regulator_; }
  bool active() const { return regulator_->active(); }
  // Regulation-active time and the nRT cores' L3 accesses and cycles during it (Eq. 1).
  TimeNs active_ns() const { return active_ns_; }
  double active_l3(std::size_t entity) const { return active_l3_.at(entity); }
  double active_cycles(std::size_t entity) const { return active_cycles_.at(entity); }
  int activations() const { return activations_; }
  // Closes an activation still open at the end of the simulation (for the accounting only).
  void finish(TimeNs now);

 private:
  struct Work {
    enum class Kind : std::uint8_t { Enable, Disable, Sample, Tick, Read } kind;
    std::size_t index = 0;
    std::vector<CounterValue> counters;
    TimeNs origin = -1;  // when the sample was published (self) or read (external)
  };

  void enqueue(Work w, TimeNs now);
  void start_next(TimeNs now);
  void stage_done(TimeNs now);
  void decide(Work& w, TimeNs now);
  void publish(TimeNs origin, TimeNs now);
  void rearm_tick();
  void activation_begin(TimeNs now);
  void activation_end(TimeNs now);
  void window_probe(TimeNs now, bool complete);
  std::vector<CounterValue> read_counters(std::size_t entity, TimeNs now);

  ControllerConfig cfg_;
  std::unique_ptr<Regulator> regulator_;
  CostStream callback_cost_;
  CostStream read_cost_;
  MessageBus& bus_;
  Runtime& rt_;
  Recorder& rec_;
  std::vector<NrtNodeModel*> nrt_;
  std::vector<int> links_;
  std::vector<CostStream> latency_;
  std::function<void(TimeNs)> on_inactive_;
  Distribution message_latency_;
  std::uint64_t seed_;

  std::deque<Work> queue_;
  bool busy_ = false;
  Work current_{};
  int stage_ = 0;  // a read: 0 reading the counters, 1 control logic
  TimeNs read_started_ = 0;
  Commands out_;

  Timer done_timer_;
  Timer tick_timer_;
  Timer poll_timer_;
  Timer probe_timer_;

  // Accounting.
  bool was_active_ = false;
  TimeNs active_since_ = 0;
  TimeNs active_ns_ = 0;
  int activations_ = 0;
  std::vector<Pmu> active_start_;
  std::vector<double> active_l3_, active_cycles_;
  std::vector<double> window_l3_;
  TimeNs window_start_ = 0;
  std::size_t window_index_ = 0;
  std::vector<double> last_sample_l3_, last_sample_cycles_;  // bandwidth counter in the trace
};

}  // namespace rosguard::sim

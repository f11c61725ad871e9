// The controller node: the shared controller engine (model/engine/controller_driver.h) on its
// core, with simulated costs around it.
//
// It serves one callback at a time, first come first served: RT enable / disable signals, samples
// published by nRT nodes (self-sampling), reads of the nRT cores' counters (external sampling,
// when the driver asks for them), and the regulation-period timer. Each callback costs
// controller_callback_us (plus external_read_us for a read); the driver is called at the
// callback's end with that time, and the commands it returns are published then and reach the
// nRT node message_latency_us later. On a core of its own the callbacks just take their time; on a
// core it shares with a node (run_on()) they are executed by that core at the highest priority,
// preempting the node's callbacks, throttle loop and work, as the controller thread does on hw.
// The driver's window accounting reads the entities' PMUs at
// the exact boundary (instrumentation, no cost).
//
// Contract: a SystemC module; wired by the System before the simulation starts (add_entity()).
// Inputs are called from SystemC processes at the current time.
#pragma once

#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <systemc>
#include <vector>

#include "engine/controller_driver.h"
#include "kernel/runtime.h"
#include "nodes/costs.h"
#include "nodes/recorder.h"
#include "platform/core.h"
#include "platform/pmu.h"

namespace rosguard::sim {

struct ControllerConfig {
  int core = 0;
  Sampling sampling = Sampling::Self;
  TimeNs sampling_period_ns = 1'000'000;
  double line_bytes = 64;  // bytes per L3 access, for the traffic accounting
  std::vector<PmuEvent> metric_events;
};

// A regulated entity as the controller sees it: where its commands go (called when a command
// arrives, with the measurement time of the sample that caused it or -1) and its core's PMU.
struct ControlledEntity {
  std::string name;
  int core = 0;  // where its node runs (the latency of the commands sent to it)
  std::function<void(Command, TimeNs cause)> deliver;
  std::function<const Pmu&()> pmu;  // brought up to the current time
};

class Controller : public sc_core::sc_module, private EntityMeter {
 public:
  Controller(const sc_core::sc_module_name& name, ControllerConfig config,
             std::unique_ptr<Regulator> regulator, const CostParams& costs, std::uint64_t seed,
             MessageBus& bus, Runtime& rt, Recorder& rec);

  int core() const { return cfg_.core; }
  // Wiring (elaboration): the regulated entities in entity order.
  void add_entity(ControlledEntity entity);
  // Wiring: the controller shares `core` with a node; its callbacks run there.
  void run_on(Core* core) { core_ = core; }
  // Called whenever regulation stops (an activation ended).
  void on_inactive(std::function<void(TimeNs)> fn) { on_inactive_ = std::move(fn); }

  // Inputs (messages delivered, or direct calls for the virtual RT node of an RT-less scenario).
  void enable(std::size_t rt, TimeNs now);
  void disable(std::size_t rt, TimeNs now);
  void sample(std::size_t entity, std::vector<CounterValue> counters, TimeNs published, TimeNs now);

  bool active() const { return driver_.active(); }
  const ControllerDriver& driver() const { return driver_; }
  // Closes an activation still open at the end of the simulation (for the accounting only).
  void finish(TimeNs now);

 private:
  struct Work {
    enum class Kind : std::uint8_t { Enable, Disable, Sample, Tick, Read } kind;
    std::size_t index = 0;
    std::vector<CounterValue> counters;
    TimeNs origin = -1;  // when the sample was published (self) or read (external)
  };

  EntityReading read(std::size_t entity, TimeNs t) override;
  void enqueue(Work w, TimeNs now);
  void start_next(TimeNs now);
  void stage_done(TimeNs now);
  void decide(Work& w, TimeNs now);
  void handle_output(TimeNs now);
  void rearm(Timer& timer, std::optional<TimeNs> when);
  void spend(TimeNs now, TimeNs cost);  // the current stage takes `cost`, then stage_done()
  std::vector<CounterValue> read_counters(std::size_t entity, TimeNs now);

  ControllerConfig cfg_;
  ControllerDriver driver_;
  CostStream callback_cost_;
  CostStream read_cost_;
  MessageBus& bus_;
  Recorder& rec_;
  std::vector<ControlledEntity> entities_;
  Core* core_ = nullptr;  // a core shared with a node, or null (a core of its own)
  std::vector<int> links_;
  std::vector<CostStream> latency_;
  std::function<void(TimeNs)> on_inactive_;
  CostParams costs_;
  std::uint64_t seed_;

  std::deque<Work> queue_;
  bool busy_ = false;
  Work current_{};
  int stage_ = 0;  // a read: 0 reading the counters, 1 control logic
  TimeNs read_started_ = 0;
  DriverOutput out_;

  Timer done_timer_;
  Timer tick_timer_;
  Timer poll_timer_;
  Timer probe_timer_;
};

}  // namespace rosguard::sim

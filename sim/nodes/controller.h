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
// Overflow sampling (MemGuard) has no controller in the loop: the baseline read at each
// activation is free (the handler reads its own PMU), every entity's core is armed with its
// overflow limits (Core::arm_overflow) after every input, and at a crossing the core keeps
// working for overflow_irq_us (the interrupt and its handler), after which the handler reads the
// counters, the engine decides and a THR takes hold at once on that core; period boundaries are
// served at the boundary, and every other command reaches its core one overflow_irq_us later.
// Mmio sampling (MemPol): each poll of a core costs mmio_poll_us on the controller (reading its
// counters through debug registers, comparing, halting it: no callback cost on top), and the
// commands take hold at once (the controller halts and resumes the core itself); boundaries are
// served at the boundary.
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
  Core* core_model = nullptr;       // its core (overflow sampling arms its PMU)
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
  // `from_core`: the sender's core (the controller's own for a direct call).
  void enable(std::size_t rt, TimeNs now, int from_core);
  void disable(std::size_t rt, TimeNs now, int from_core);
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
    bool local = true;   // woken on the controller's core (its timers, a node beside it)
    bool timer = false;  // the first work of a timer's expiry: it pays the wake-up
  };

  EntityReading read(std::size_t entity, TimeNs t) override;
  void enqueue(Work w, TimeNs now);
  void start_next(TimeNs now);
  void stage_done(TimeNs now);
  void decide(Work& w, TimeNs now);
  void handle_output(TimeNs now, bool from_handler = false);
  void rearm(Timer& timer, std::optional<TimeNs> when);
  void rearm_timers();
  bool direct() const;  // overflow / mmio: no messages, no callbacks around the decisions
  void direct_sample(std::size_t entity, TimeNs now, TimeNs cause);
  void arm_overflow(std::size_t entity);
  void overflow_hit(std::size_t entity, TimeNs now);
  void spend(TimeNs now, TimeNs cost);  // the current stage takes `cost`, then stage_done()
  TimeNs callback_cost(const Work& w);  // the callback's cost, by where its input came from
  std::vector<CounterValue> read_counters(std::size_t entity, TimeNs now);

  ControllerConfig cfg_;
  ControllerDriver driver_;
  CostStream callback_cost_;
  std::optional<CostStream> local_callback_cost_;  // controller_callback_local_us
  std::optional<CostStream> wakeup_cost_;          // timer_wakeup_us
  CostStream read_cost_;
  std::optional<CostStream> irq_cost_;   // overflow sampling
  std::optional<CostStream> mmio_cost_;  // mmio sampling
  MessageBus& bus_;
  Runtime& rt_;
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
  std::vector<std::unique_ptr<Timer>> irq_timers_;  // per entity: overflow -> handler
  std::vector<TimeNs> overflow_at_;                 // per entity: the crossing being handled
};

}  // namespace rosguard::sim

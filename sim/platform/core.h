// A simulated core: a priority-preemptive executor of one workload (lowest priority) and of
// callbacks, with a PMU.
//
// What runs, highest priority first: a callback of a controller that shares the core
// (Prio::Controller, as its thread sits above the node's threads on hw), a CFB callback
// (Prio::Cfb), the THR idle loop while
// throttled, a PMC / publishing callback (Prio::Pmc), the workload's restart after a preemption
// (Prio::Resume: where the platform has costs.preemption_us, a callback that preempts the running
// workload is followed by one of that cost, in which the workload makes no progress), the
// workload (an RT job or the nRT node's NCT), else nothing (the core idles and its cycle counter
// stops, as in WFI). Equal priorities run in the order posted. Callbacks take a fixed time and move
// no data; the THR loop counts cycles and instructions and moves no data; the workload progresses
// at the rates of the memory model. So a throttled core's nominal work does not progress and it
// creates no traffic.
//
// Contract: a SystemC module, driven from SystemC processes at the current simulated time.
// Mutators first bring the PMU and the workload up to now, then reschedule; they may be called
// from any process (including from a callback's `done`). The WorkloadRun passed to start_work()
// must outlive the core's use of it.
#pragma once

#include <array>
#include <functional>
#include <optional>
#include <string>
#include <systemc>
#include <vector>

#include "backend/trace.h"
#include "kernel/runtime.h"
#include "nodes/costs.h"
#include "platform/memory_system.h"
#include "platform/pmu.h"
#include "workload/profile.h"

namespace rosguard::sim {

class Core : public sc_core::sc_module {
 public:
  SC_HAS_PROCESS(Core);
  enum class Prio : std::uint8_t { Controller = 0, Cfb = 1, Pmc = 2, Resume = 3 };
  using Done = std::function<void(TimeNs)>;

  // `seed`: the run's (RunConfig::seed), for the draws of the preemption cost.
  Core(const sc_core::sc_module_name& name, int id, const SimPlatform& platform,
       MemorySystem& memory, Runtime& rt, TraceSink* trace, std::uint64_t seed);

  int id() const { return id_; }
  int cluster() const { return cluster_; }

  // Runs `run` at the lowest priority from now on; `on_end(t)` is called when it finishes (it
  // may restart the run, start another or stop).
  void start_work(WorkloadRun* run, Done on_end);
  void stop_work();
  // Queues a callback of `cost_ns` of execution time; `done(t)` is called when it completes.
  void post(Prio prio, TimeNs cost_ns, std::string label, Done done);
  // Enters (true) or leaves (false) the THR idle loop.
  void set_throttle(bool on);
  bool throttled() const { return thr_; }

  // Overflow interrupt (overflow sampling): `fire(t)` is called once, at the first time one of
  // the limits is crossed: sum_e(bytes_per_count[e] x count_e) > at_bytes, over the PMU's
  // cumulative counts, with one count per weighted event of slack so that the counters as read
  // (whole counts) are past the limit too. The rates are constant between dispatches (memory
  // model changes, callbacks, throttling), so the crossing is computed, not polled: re-computed
  // at every dispatch. A new arm replaces the old; firing disarms.
  struct OverflowLimit {
    std::array<double, kPmuEvents> bytes_per_count{};
    double at_bytes = 0.0;
  };
  void arm_overflow(std::vector<OverflowLimit> limits, Done fire);
  void disarm_overflow();

  // The PMU and the workload's progress, brought up to now.
  const Pmu& pmu();
  double work_retired();

  // What the memory system needs to know of this core.
  CoreDemand demand() const;
  // The memory system re-solved: bring counters up to now and take the new rates.
  void memory_changed();

 private:
  enum class Running : std::uint8_t { Idle, Callback, Thr, Work };
  struct Pending {
    Prio prio;
    std::uint64_t seq;
    TimeNs remaining;
    std::string label;
    Done done;
    TimeNs started = -1;
  };

  void wake();
  void sync(TimeNs now);
  void dispatch(TimeNs now);
  void arm(TimeNs now);
  std::size_t top_callback() const;  // index of the callback to run, or npos
  std::optional<TimeNs> overflow_crossing(TimeNs now) const;
  void overflow_rearm(TimeNs now);
  void overflow_timer(TimeNs now);

  int id_;
  int cluster_;
  double f_ghz_;
  double callback_ipc_;
  double idle_ipc_;
  MemorySystem& memory_;
  std::size_t mem_index_ = 0;
  Runtime& rt_;
  TraceSink* trace_;

  std::optional<CostStream> preemption_cost_;  // costs.preemption_us
  std::vector<Pending> callbacks_;
  std::uint64_t seq_ = 0;
  bool thr_ = false;
  WorkloadRun* run_ = nullptr;
  // The footprint of the last workload run here: its lines stay in the L3 (not resident: aging
  // out) while the core does something else.
  const void* held_workload_ = nullptr;
  Done on_end_;

  Running running_ = Running::Idle;
  std::size_t running_cb_ = 0;
  CoreRates rates_;
  TimeNs last_ = 0;
  Pmu pmu_;
  CoreDemand reported_;
  bool reported_valid_ = false;
  sc_core::sc_event wake_ev_;
  TimeNs wake_at_ = -1;   // when the running callback or workload segment ends (-1: never)
  TimeNs armed_at_ = -1;  // the notification pending in the kernel (-1: none)

  std::vector<OverflowLimit> overflow_;
  Done overflow_fire_;
  Timer overflow_timer_;
};

}  // namespace rosguard::sim

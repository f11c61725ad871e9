// The nRT node archetype: four callbacks on four threads pinned to the node's core, by priority
// CFB (commands) > THR (the throttle: an idle loop) > PMC (self-sampling) > NCT (the workload).
//
// Contract:
// - Built, started and shut down by the engine's thread. start() returns when every thread runs
//   with its scheduling applied (outcomes() says where a fallback was taken). begin() lets NCT
//   run the workload; end_loop() stops a loop-mode workload; shutdown() (also run by the
//   destructor, on every exit path) forces the node to nominal, stops and joins every thread and
//   kills an external command. No thread of the node is left spinning or under SCHED_FIFO.
// - CFB alone owns the nRT engine (model/engine/nrt_driver.h: the state machine, its side
//   effects, the throttle bookkeeping and the watchdog); other threads see its state through an
//   atomic copy. THR is started by CFB through a futex wake (the paper's zero-time timer) and
//   spins until the state leaves THR: CFB, a higher priority on the same core, preempts the
//   spinner when REPLENISH / OFF / ON arrives. PMC owns the sampling period (SampleSchedule).
// - Watchdog: when the node is not OFF and the controller (commands or keepalives) has been
//   silent for watchdog_ns, CFB returns the node to nominal (OFF) by itself.
// - Results (observations, trace, counts) are read by the engine after shutdown().
#pragma once

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "engine/nrt_driver.h"
#include "hw/common/sys.h"
#include "hw/executor/executor.h"
#include "hw/nodes/messages.h"
#include "hw/pmc_source/pmc_source.h"
#include "hw/throttle/throttle.h"
#include "hw/topic/topic.h"
#include "hw/workload/workload.h"
#include "scenario/scenario.h"

namespace rosguard::hw {

struct NrtConfig {
  std::string name;
  std::size_t entity = 0;
  int core = 0;
  Sampling sampling = Sampling::Self;
  TimeNs sampling_period_ns = kNsPerMs;
  TimeNs watchdog_ns = 100 * kNsPerMs;
  NrtMode mode = NrtMode::Loop;
  SchedClass sched = SchedClass::Fifo;
  // How THR holds the core (hw/throttle/throttle.h); Freezer needs freezer_root (commands only).
  ThrottleKind throttle = ThrottleKind::Fifo;
  std::string freezer_root;
  // No workload of its own: the node regulates whatever else runs on its core (rosguard guard).
  // No NCT thread; external sampling only; the counter group comes from set_group().
  bool foreign = false;
  bool keep_measurements = true;  // false: no delays or THR entries kept (a daemon: bounded memory)
  std::vector<std::string> group_events;  // opened on the workload; the metric's come first
  std::size_t metric_events = 1;          // how many of them the regulator gets
  bool trace = false;
};

// Counters of an external command, cumulative across its restarts (loop mode): each process gets
// its own perf group (inherit: its children count too); the values of finished processes are
// added as a base. Readers see one immutable generation through an atomic pointer, so the NCT
// thread never blocks them (no lock shared across priorities).
class ProcessCounters : public CounterGroup {
 public:
  explicit ProcessCounters(std::size_t n) : n_(n) {}
  std::size_t size() const override { return n_; }
  void read(std::span<CounterValue> out) override;
  // NCT thread: the next process's group (its predecessor has exited).
  void next(std::unique_ptr<CounterGroup> group);

 private:
  struct Generation {
    std::unique_ptr<CounterGroup> group;
    std::vector<CounterValue> base;
  };
  std::size_t n_;
  std::vector<std::unique_ptr<Generation>> generations_;  // owned until the node is destroyed
  std::atomic<Generation*> current_{nullptr};
};

class NrtRunner {
 public:
  NrtRunner(NrtConfig config, const WorkloadInfo& workload, const PmcSource& source,
            Topic<ControlMsg>& control, Topic<SampleMsg>& samples, Waker& engine_waker,
            RtThread::ErrorHandler on_error, TimeNs origin);
  ~NrtRunner();
  NrtRunner(const NrtRunner&) = delete;
  NrtRunner& operator=(const NrtRunner&) = delete;

  // Foreign nodes, before start(): the core's counters.
  void set_group(std::unique_ptr<CounterGroup> group) { group_ = std::move(group); }
  // The freezer's cgroup (throttle Freezer), where a foreign node's host puts the core's processes.
  FreezerCgroup* cgroup() { return cgroup_.get(); }
  void start();
  void begin();
  void end_loop();
  void shutdown();

  const NrtConfig& config() const { return cfg_; }
  NodeState state() const { return state_.load(std::memory_order_acquire); }
  bool once_done() const { return once_done_.load(std::memory_order_acquire); }
  CounterGroup& group() { return *group_; }
  // After start(), a built-in workload: the thread it runs on (its counters' target).
  pid_t workload_tid() const { return nct_ ? nct_->tid() : 0; }
  const WorkCounters& work() const { return work_; }
  bool builtin() const { return builtin_ != nullptr; }
  std::uint64_t units_per_run() const { return builtin_ ? builtin_->units_per_run() : 0; }
  // Command workloads: completed runs (processes that exited) so far.
  std::uint64_t completed_runs() const { return completed_.load(std::memory_order_acquire); }

  // After shutdown():
  std::vector<SchedOutcome> outcomes() const;
  const NrtDriver& driver() const { return driver_; }
  std::uint64_t throttles() const { return driver_.throttles(); }
  TimeNs throttled_ns() const { return driver_.throttled_ns(); }
  std::uint64_t watchdog_fired() const { return driver_.watchdog_fired(); }
  double once_time_us() const { return once_time_us_; }
  double once_fraction() const { return once_fraction_; }
  const std::vector<double>& activation_delays_us() const { return activation_us_; }
  // PMC callback: group read + publish; pmc read: the group read alone.
  const std::vector<double>& pmc_callbacks_us() const { return pmc_us_; }
  const std::vector<double>& pmc_reads_us() const { return read_us_; }
  const std::vector<double>& sampling_overheads_us() const { return overhead_us_; }
  // When the THR callback started spinning, each time (CLOCK_MONOTONIC ns).
  const std::vector<TimeNs>& thr_entries() const { return thr_entries_; }
  std::vector<const TraceLog*> traces() const { return {&cfb_trace_, &thr_trace_, &pmc_trace_}; }

 private:
  void cfb_main();
  void thr_main();
  void pmc_main();
  void nct_main();
  void nct_command();
  void take_sample(bool periodic, TimeNs& cpu_mark);
  void apply_effects(const NrtEffects& fx, TimeNs now, TimeNs& state_since);

  NrtConfig cfg_;
  const WorkloadInfo& workload_;
  const PmcSource& source_;
  Topic<ControlMsg>& control_;
  Topic<SampleMsg>& samples_;
  Waker& engine_waker_;
  RtThread::ErrorHandler on_error_;
  TimeNs origin_;
  std::string track_state_, track_thr_;

  ThrottleSched sched_;
  std::unique_ptr<FreezerCgroup> cgroup_;  // the command's processes (freezer); outlives threads
  std::unique_ptr<Throttler> throttler_;
  std::unique_ptr<BuiltinWorkload> builtin_;
  WorkCounters work_;
  std::unique_ptr<CounterGroup> group_;
  ProcessCounters* process_counters_ = nullptr;
  std::size_t control_sub_ = 0, sample_pub_ = 0;

  Waker cfb_waker_, thr_waker_, pmc_waker_, nct_waker_;
  Fd stop_fd_;  // eventfd: wakes an NCT thread waiting on an external command
  std::atomic<NodeState> state_{NodeState::Off};
  std::atomic<bool> stop_{false};
  std::atomic<bool> begun_{false};
  std::atomic<bool> nct_stop_{false};
  std::atomic<bool> sample_now_{false};
  std::atomic<bool> once_done_{false};
  std::atomic<std::uint64_t> completed_{0};
  bool shut_ = false;

  // Written by one thread each, read after join.
  NrtDriver driver_;  // CFB thread
  double once_time_us_ = 0.0;
  double once_fraction_ = 0.0;
  static constexpr int kOverheadPeriods = 10;
  int overhead_periods_ = 0;  // PMC thread only
  std::vector<double> activation_us_, pmc_us_, read_us_, overhead_us_;
  std::vector<TimeNs> thr_entries_;  // THR thread
  TraceLog cfb_trace_, thr_trace_, pmc_trace_;

  std::unique_ptr<RtThread> cfb_, thr_, pmc_, nct_;
};

}  // namespace rosguard::hw

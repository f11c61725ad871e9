// The controller node archetype: one thread that owns the Regulator (model/regulator), receives
// the RT nodes' enable / disable signals and (self-sampling) the nRT nodes' PMC samples, polls
// the nRT counters itself under external sampling, and publishes commands on each nRT node's
// control topic.
//
// Contract:
// - Every Regulator call comes from the controller thread, with non-decreasing CLOCK_MONOTONIC
//   ns. Under external sampling the controller reads every entity's group as soon as an
//   activation starts (the regulator's baseline), then every sampling period.
// - While an nRT node is not OFF the controller sends it a keepalive at least every
//   keepalive_ns, so the node's watchdog only fires when the controller is really silent.
// - on_window(start, t) is called on the controller thread when an activation starts (first RT
//   node started) and ends (last RT node finished); the engine snapshots counters there.
// - fail_after_ns (tests only) makes the thread stop answering that long after the first
//   activation, without sending OFF: a crashed controller.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "hw/executor/executor.h"
#include "hw/nodes/messages.h"
#include "hw/pmc_source/pmc_source.h"
#include "hw/topic/topic.h"
#include "regulator/regulator.h"

namespace rosguard::hw {

struct ControllerConfig {
  int core = 0;
  SchedClass sched = SchedClass::Fifo;
  Sampling sampling = Sampling::Self;
  TimeNs sampling_period_ns = kNsPerMs;
  TimeNs keepalive_ns = 25 * kNsPerMs;
  std::vector<int> entity_cores;         // for the trace
  std::vector<std::size_t> group_sizes;  // events opened per entity (metric's first)
  std::size_t metric_events = 1;
  bool trace = false;
  TimeNs fail_after_ns = -1;
};

class Controller {
 public:
  using WindowHook = std::function<void(bool start, TimeNs t)>;
  Controller(ControllerConfig config, std::unique_ptr<Regulator> regulator,
             Topic<RtEventMsg>& rt_topic, Topic<SampleMsg>& samples,
             std::vector<Topic<ControlMsg>*> controls, std::vector<CounterGroup*> groups,
             WindowHook on_window, Waker& engine_waker, RtThread::ErrorHandler on_error,
             TimeNs origin);
  ~Controller();
  Controller(const Controller&) = delete;
  Controller& operator=(const Controller&) = delete;

  // Before start(): the counter groups of the entities (external sampling, window snapshots).
  void set_groups(std::vector<CounterGroup*> groups) { groups_ = std::move(groups); }
  void start();
  void shutdown();

  SchedOutcome outcome() const { return thread_ ? thread_->outcome() : SchedOutcome{}; }
  // Activations that have ended (OFF sent); the engine waits for it after the RT nodes finish.
  int windows_closed() const { return closed_.load(std::memory_order_acquire); }
  int windows_opened() const { return opened_.load(std::memory_order_acquire); }
  // Enable / disable signals processed so far (the engine waits for all it knows were sent).
  int rt_events() const { return rt_events_.load(std::memory_order_acquire); }
  bool failed_on_purpose() const { return faulted_.load(std::memory_order_acquire); }
  TimeNs fault_time() const { return fault_t_; }
  const std::vector<double>& external_reads_us() const { return reads_us_; }
  const TraceLog& trace() const { return trace_; }
  std::uint64_t commands_sent() const { return commands_; }

 private:
  void main();
  void send(const Commands& out, TimeNs cause);
  void sample_entity(std::size_t e, TimeNs measured, const CounterValue* values, TimeNs cause);
  void external_round();

  ControllerConfig cfg_;
  std::unique_ptr<Regulator> reg_;
  Topic<RtEventMsg>& rt_topic_;
  Topic<SampleMsg>& samples_;
  std::vector<Topic<ControlMsg>*> controls_;
  std::vector<std::size_t> control_pubs_;
  std::vector<CounterGroup*> groups_;
  WindowHook on_window_;
  Waker& engine_waker_;
  RtThread::ErrorHandler on_error_;
  TimeNs origin_;

  Waker waker_;
  std::size_t rt_sub_ = 0, sample_sub_ = 0;
  std::atomic<bool> stop_{false};
  std::atomic<int> closed_{0};
  std::atomic<int> opened_{0};
  std::atomic<int> rt_events_{0};
  std::atomic<bool> faulted_{false};
  TimeNs fault_t_ = 0;
  TimeNs last_t_ = 0;
  Commands out_;
  std::uint64_t commands_ = 0;
  std::vector<double> reads_us_;
  std::vector<std::string> counter_names_;
  std::vector<TimeNs> last_sample_t_;
  std::vector<double> last_bytes_;
  TraceLog trace_;
  std::unique_ptr<RtThread> thread_;
  bool shut_ = false;
};

}  // namespace rosguard::hw

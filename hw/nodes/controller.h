// The controller node archetype: one thread around the shared controller engine
// (model/engine/controller_driver.h). It receives the RT nodes' enable / disable signals and
// (self-sampling) the nRT nodes' PMC samples, reads the nRT counters when the driver asks
// (external sampling), publishes the driver's commands and keep-alives on each nRT node's control
// topic, and sleeps on a futex until the next input or the driver's next wake-up.
//
// Contract:
// - Every driver call comes from the controller thread (or from the caller of serve() when the
//   thread is not started: tests), with non-decreasing times from config.clock.
// - The driver's accounting reads the entities through the EntityMeter given here, on the
//   controller thread, at each activation edge.
// - Overflow sampling (MemGuard): each entity's overflow counters (set_overflow) are claimed by
//   the thread that serves (their signal wakes it) and armed from the regulator's overflow limits
//   after every input that changed them (model/regulator/regulator.h, overflow_arm). A signal
//   makes the controller read that entity's group at once and sample it; a THR it causes carries
//   the signal's time as its cause. Window boundaries read every entity (the driver asks).
// - fail_after_ns (tests only) makes the thread stop answering that long after its first THR
//   command, without sending OFF: a controller that crashes while an nRT node is throttled
//   (counted from the command, not from a clock time, so that a slow start cannot move the fault
//   before the first throttle).
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "engine/controller_driver.h"
#include "hw/common/clock.h"
#include "hw/executor/executor.h"
#include "hw/nodes/messages.h"
#include "hw/pmc_source/overflow.h"
#include "hw/pmc_source/pmc_source.h"
#include "hw/topic/topic.h"

namespace rosguard::hw {

// What the controller did, for a host that shows it (rosguard guard publishes and logs these).
// Pushed on the controller thread into a lock-free ring (ControllerConfig::notes); a full ring
// drops the note, never blocks the controller.
struct ControllerNote {
  enum class Kind : std::uint8_t {
    Sample,        // entity's counters read: value = bytes accounted, value2 = first metric counter
                   // (cumulative); used / budget: its account's window so far, in bytes
    Budget,        // percent of the entity's window budget used after a sample (value)
    WindowClosed,  // a window closed: value = bytes used in it
    Command,       // command sent to entity
    Activation,    // regulation active (active = true) or not
    Policy,        // a new policy took over (post_policy)
  };
  Kind kind = Kind::Sample;
  TimeNs t = 0;
  std::size_t entity = 0;
  double value = 0.0, value2 = 0.0;
  double used = 0.0, budget = 0.0;
  Command command = Command::Off;
  TimeNs cause = 0;  // Command: the read that caused it
  bool active = false;
};
using NoteRing = SpscRing<ControllerNote, 8192>;

struct ControllerConfig {
  int core = 0;
  SchedClass sched = SchedClass::Fifo;
  Sampling sampling = Sampling::Self;
  TimeNs sampling_period_ns = kNsPerMs;
  TimeNs keepalive_ns = 25 * kNsPerMs;
  double max_bytes_per_ns = 0.0;         // ControllerDriverConfig's: paced reads of a time metric
  std::vector<int> entity_cores;         // for the trace
  std::vector<std::size_t> group_sizes;  // events opened per entity (metric's first)
  std::size_t metric_events = 1;
  bool trace = false;
  TimeNs fail_after_ns = -1;
  std::size_t rt_count = 1;                // RT indices the enable / disable signals may carry
  std::function<TimeNs()> clock = now_ns;  // CLOCK_MONOTONIC; tests inject their own
  bool keep_measurements =
      true;                   // false: no read timings or signal records (a daemon: bounded memory)
  NoteRing* notes = nullptr;  // optional: what the controller did, for its host
  Waker* notes_waker = nullptr;  // notified after each batch of notes
};

// One enable / disable signal as the controller saw it: sent (the publisher's stamp: its
// CLOCK_MONOTONIC, or a DDS source timestamp mapped onto it) and received (taken by the
// controller thread).
struct SignalRecord {
  std::size_t rt = 0;
  bool started = false;
  TimeNs t_sent = 0;
  TimeNs t_received = 0;
};

// One overflow signal the controller took (overflow sampling): the counter that signalled, how
// it was armed and what the read it caused found.
struct OverflowRecord {
  std::size_t entity = 0;
  std::size_t event = 0;  // the lowest metric event whose counter signalled
  TimeNs t_armed = 0;     // CLOCK_MONOTONIC: armed, signal handled, counters read
  TimeNs t_signal = 0;
  TimeNs t_read = 0;
  std::uint64_t period = 0;   // that counter's period (counts)
  std::uint64_t at_arm = 0;   // its event's raw count when it was armed
  std::uint64_t at_read = 0;  // and at the read the signal caused
  bool throttled = false;     // the read sent THR to the entity
};

class Controller {
 public:
  Controller(ControllerConfig config, std::unique_ptr<Regulator> regulator,
             Topic<RtEventMsg>& rt_topic, Topic<SampleMsg>& samples,
             std::vector<Topic<ControlMsg>*> controls, EntityMeter* meter, Waker& engine_waker,
             RtThread::ErrorHandler on_error, TimeNs origin);
  ~Controller();
  Controller(const Controller&) = delete;
  Controller& operator=(const Controller&) = delete;

  // Before start(): the counter groups of the entities (external sampling).
  void set_groups(std::vector<CounterGroup*> groups) { groups_ = std::move(groups); }
  // Before start(), overflow sampling: the entities' overflow counters (null: none), the metric's
  // events in order.
  void set_overflow(std::vector<std::unique_ptr<OverflowCounters>> counters);
  void start();
  void shutdown();
  // Any thread: a new policy for the next windows (Regulator::set_policy), taken over by the
  // controller thread at its next pass; one pending at a time (a later post replaces it).
  void post_policy(std::unique_ptr<Policy> policy);
  // One pass: every pending input, then every wake-up due now. Returns whether it did anything.
  // The controller thread loops over it; tests call it directly (thread not started).
  bool serve();

  SchedOutcome outcome() const { return thread_ ? thread_->outcome() : SchedOutcome{}; }
  int windows_opened() const { return opened_.load(std::memory_order_acquire); }
  // Enable / disable signals processed so far (the engine waits for all it knows were sent).
  int rt_events() const { return rt_events_.load(std::memory_order_acquire); }
  // Disable signals (ends of jobs) of RT node `rt` processed so far.
  int rt_finished(std::size_t rt) const {
    return rt < cfg_.rt_count ? finished_[rt].load(std::memory_order_acquire) : 0;
  }
  bool failed_on_purpose() const { return faulted_.load(std::memory_order_acquire); }
  // After shutdown() (or from the serve() caller):
  const ControllerDriver& driver() const { return driver_; }
  const std::vector<double>& external_reads_us() const { return reads_us_; }
  const std::vector<SignalRecord>& signals() const { return signals_; }
  const TraceLog& trace() const { return trace_; }
  const std::vector<OverflowRecord>& overflows() const { return overflows_; }
  std::uint64_t notes_dropped() const { return notes_dropped_; }

 private:
  void main();
  void handle();
  void send(const DriverCommand& c);
  void read_entities(const std::vector<std::size_t>& entities,
                     const OverflowSink::Hit* hit = nullptr);
  bool arm_overflow(std::size_t e);
  void take_overflows(bool& busy);
  void trace_bandwidth(std::size_t e, TimeNs measured, double bytes);
  TimeNs now();
  void note(const ControllerNote& n);

  ControllerConfig cfg_;
  ControllerDriver driver_;
  Topic<RtEventMsg>& rt_topic_;
  Topic<SampleMsg>& samples_;
  std::vector<Topic<ControlMsg>*> controls_;
  std::vector<std::size_t> control_pubs_;
  std::vector<CounterGroup*> groups_;
  Waker& engine_waker_;
  RtThread::ErrorHandler on_error_;
  TimeNs origin_;

  Waker waker_;
  std::size_t rt_sub_ = 0, sample_sub_ = 0;
  std::atomic<bool> stop_{false};
  std::atomic<int> opened_{0};
  std::atomic<int> rt_events_{0};
  std::unique_ptr<std::atomic<int>[]> finished_;
  std::vector<SignalRecord> signals_;
  std::atomic<bool> faulted_{false};
  TimeNs first_throttle_ = -1;  // when the first THR command was sent (fail_after_ns)
  TimeNs last_t_ = 0;
  DriverOutput out_;
  std::vector<double> reads_us_;
  std::vector<std::string> counter_names_;
  std::vector<TimeNs> last_sample_t_;
  TraceLog trace_;
  std::atomic<Policy*> pending_policy_{nullptr};
  std::uint64_t notes_dropped_ = 0;
  // Overflow sampling: per entity its counters, whether they are armed for the limits kept here
  // (and from which counts, for the records), and the records of the signals taken.
  struct Armed {
    bool armed = false;
    std::vector<OverflowLimit> limits;
    std::vector<std::uint64_t> periods, at;
    TimeNs t = 0;
  };
  std::unique_ptr<OverflowSink> sink_;  // outlives the counters that mark it
  std::vector<std::unique_ptr<OverflowCounters>> overflow_;
  bool claimed_ = false;
  std::vector<Armed> armed_;
  std::vector<OverflowRecord> overflows_;
  std::unique_ptr<RtThread> thread_;
  bool shut_ = false;
};

}  // namespace rosguard::hw

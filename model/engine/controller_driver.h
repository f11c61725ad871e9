// The controller's engine: the regulator plus everything around it that is neither physics nor
// OS, shared by the sim and hw controllers (which only add simulated costs, or a real thread and
// futex waits, around it).
//
// Contract:
// - One owner calls every method from one thread with non-decreasing times `t` (integer ns). The
//   driver never reads a clock; counter values come in through sample() and the EntityMeter.
// - Inputs: rt_signal() (an RT node's enable / disable), sample() (cumulative counters of one
//   entity, with the time they were measured; under overflow sampling, the reading the overflow
//   interrupt took), and the due wake-ups: tick() at next_tick(),
//   read_due() at next_read(), window_due() at next_window(), keepalive_due() at
//   next_keepalive() (wake() runs every one of them that is due). A host may serve a wake-up
//   late (after a simulated callback cost, or a late thread); it must not serve it early.
// - Outputs go to a DriverOutput the caller owns and clears: commands for the entities (with the
//   measurement time of the sample that caused them), entities whose counters the host must read
//   and pass to sample() (external and mmio sampling: a baseline read at each activation, then
//   every sampling period; overflow sampling: the baseline read and one read at every window
//   boundary, no periodic reads), entities whose overflow
//   interrupts to re-arm (overflow sampling), entities that need a keep-alive, and events for
//   tracing.
// - Accounting: at each activation edge (and regulation-window boundary when windows are
//   recorded) the driver reads every entity through the EntityMeter, synchronously, and keeps
//   the increases: regulation-active time, per-entity bytes / cycles / work while active, and
//   the traffic of each regulation window.
#pragma once

#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "core/types.h"
#include "metric/metric.h"
#include "regulator/regulator.h"

namespace rosguard {

// A command for an entity, as the controller publishes it. `cause` is the measurement time of
// the sample that made the regulator send it (THR), or -1.
struct DriverCommand {
  TimeNs t = 0;
  std::size_t entity = 0;
  Command command = Command::Off;
  TimeNs cause = -1;
  bool operator==(const DriverCommand&) const = default;
};

// What the host measures of one entity: cumulative values. Any of them may stay 0 when the host
// cannot count it (then the outcome says "not applicable" where it matters).
struct EntityReading {
  double bytes = 0.0;   // memory traffic (L3 accesses x line bytes, or the metric's bytes)
  double cycles = 0.0;  // core cycles (Eq. 1); 0: not counted, bandwidth from elapsed time
  double work = 0.0;    // completed runs of the entity's workload (fractional)
};

// The host's measurement of the regulated entities, called by the driver (synchronously, on the
// driver's thread) at activation edges and window boundaries.
class EntityMeter {
 public:
  virtual ~EntityMeter() = default;
  virtual EntityReading read(std::size_t entity, TimeNs t) = 0;
};

// Traffic of one entity in one regulation window.
struct WindowUsage {
  std::size_t entity = 0;
  std::size_t index = 0;  // window number since the activation began
  TimeNs start = 0;
  TimeNs end = 0;
  double bytes = 0.0;
  bool complete = true;  // false: cut short by the end of the activation
  bool operator==(const WindowUsage&) const = default;
};

struct EngineEvent {
  enum class Kind : std::uint8_t {
    ActivationBegin,  // first RT node started: entities ON
    ActivationEnd,    // last RT node finished: entities OFF
    WindowClosed,     // a regulation window's accounting closed (value: bytes, entity)
    BudgetUsed,       // after a sample: percent of the entity's account budget used (value)
  };
  Kind kind;
  TimeNs t = 0;
  std::size_t entity = 0;
  double value = 0.0;
  bool operator==(const EngineEvent&) const = default;
};

struct DriverOutput {
  std::vector<DriverCommand> commands;
  std::vector<std::size_t> reads;       // read these entities' counters now, then sample()
  std::vector<std::size_t> keepalives;  // send these entities a keep-alive now
  // Overflow sampling: entities whose overflow interrupts must be re-armed now, from
  // regulator().overflow_limits(e) (empty limits: disarm). Every entity, after every input.
  std::vector<std::size_t> rearm;
  std::vector<EngineEvent> events;
  void clear();
};

// Regulation-active time and what the entities did during it, summed over every activation.
struct ActivationTotals {
  int activations = 0;
  TimeNs active_ns = 0;
  std::vector<EntityReading> active;  // per entity: increase over the active time
};

struct ControllerDriverConfig {
  Sampling sampling = Sampling::Self;
  TimeNs sampling_period_ns = kNsPerMs;
  TimeNs keepalive_ns = 0;      // while an entity is not OFF; 0: no keep-alives
  bool record_windows = false;  // per regulation window traffic (policies with periodic windows)
  // Periodic external reads of a metric whose top rate is known (CPU time: a core spends at most
  // one ns of it per ns): bytes an entity can use per ns at most (0: unknown). A read is then
  // also due when an ON entity could have spent its account's remainder at that rate (not sooner
  // than kMinPacedReadNs after the last), so a budget smaller than a sampling period is still
  // caught when it runs out, not up to a period later.
  double max_bytes_per_ns = 0.0;
};

// The closest paced reads (max_bytes_per_ns) follow each other.
inline constexpr TimeNs kMinPacedReadNs = 20 * kNsPerUs;

class ControllerDriver {
 public:
  // `meter` must outlive the driver (it may be null when the host never activates regulation).
  ControllerDriver(ControllerDriverConfig config, std::unique_ptr<Regulator> regulator,
                   EntityMeter* meter);

  void rt_signal(TimeNs t, std::size_t rt, bool started, DriverOutput& out);
  // `measured` is when the counters were read (self: published; external: read); processed at t.
  void sample(TimeNs t, std::size_t entity, std::span<const CounterValue> counters,
              std::optional<TimeNs> measured, DriverOutput& out);
  void tick(TimeNs t, DriverOutput& out);
  void read_due(TimeNs t, DriverOutput& out);
  void window_due(TimeNs t, DriverOutput& out);
  void keepalive_due(TimeNs t, DriverOutput& out);
  // Every wake-up that is due at t, in the order tick, reads, windows, keep-alives.
  void wake(TimeNs t, DriverOutput& out);
  // End of the run: closes the accounting of an activation still open (sends nothing).
  void finish(TimeNs t, DriverOutput& out);

  std::optional<TimeNs> next_tick() const;
  std::optional<TimeNs> next_read() const;
  std::optional<TimeNs> next_window() const { return next_window_; }
  std::optional<TimeNs> next_keepalive() const { return next_keepalive_; }
  std::optional<TimeNs> next_wakeup() const;

  bool active() const { return regulator_->active(); }
  const Regulator& regulator() const { return *regulator_; }
  // A new policy from the next window on (Regulator::set_policy).
  void set_policy(std::unique_ptr<Policy> policy) { regulator_->set_policy(std::move(policy)); }
  std::size_t entity_count() const { return regulator_->entity_count(); }
  const ActivationTotals& totals() const { return totals_; }
  const std::vector<WindowUsage>& windows() const { return windows_; }

 private:
  void after_input(TimeNs t, TimeNs cause, DriverOutput& out);
  void activation_begin(TimeNs t, DriverOutput& out);
  void activation_end(TimeNs t, DriverOutput& out);
  void close_window(TimeNs t, bool complete, DriverOutput& out);
  bool samples_externally() const;
  bool periodic_reads() const;

  ControllerDriverConfig cfg_;
  std::unique_ptr<Regulator> regulator_;
  EntityMeter* meter_;
  Commands commands_;  // the regulator's output, reused
  bool was_active_ = false;
  TimeNs active_since_ = 0;
  std::vector<EntityReading> at_activation_;
  std::vector<double> window_bytes_start_;
  TimeNs window_start_ = 0;
  std::size_t window_index_ = 0;
  void pace_read(TimeNs t);

  std::optional<TimeNs> next_read_, next_window_, next_keepalive_;
  std::optional<TimeNs> paced_read_;  // max_bytes_per_ns: before next_read_ where a budget runs out
  ActivationTotals totals_;
  std::vector<WindowUsage> windows_;
};

}  // namespace rosguard

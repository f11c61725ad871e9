// The nRT node's engine: the OFF / ON / THR state machine (model/node/nrt_node.h) with the side
// effects of each command, the throttle bookkeeping and the watchdog, shared by the sim and hw
// nRT nodes; and the self-sampling period timer.
//
// Contract:
// - NrtDriver belongs to whoever runs the node's CFB callback (the simulated core, or the CFB
//   thread of the hw node) and is called from there only, with non-decreasing times.
// - command() applies one command at the time the CFB callback ends and says what the host must
//   do now (NrtEffects): enter or leave the throttle loop, take a baseline sample and restart
//   the sampling period (ON under self-sampling), stop sampling (OFF), or make up a period that
//   ended while throttled (REPLENISH). Throttles are counted, and throttled time accumulated,
//   here: from the command that enters THR to the one that leaves it (or finish()).
// - Watchdog (watchdog_ns > 0): every message from the controller (command or keep-alive) is
//   heard(); when the node is not OFF and nothing was heard for watchdog_ns, the host calls
//   watchdog() and the node goes back to nominal by itself.
// - SampleSchedule is the self-sampling period timer (ROS 2 timer semantics: a fixed grid from
//   the baseline; a period that ends while the host cannot sample is owed once, not per period).
//   It belongs to whoever runs the PMC callback (it may be another thread than CFB's).
#pragma once

#include <cstdint>
#include <optional>

#include "core/types.h"
#include "node/nrt_node.h"

namespace rosguard {

struct NrtEffects {
  Transition transition{NodeState::Off, NodeState::Off};
  bool throttle = false;       // enter the throttle loop now
  bool unthrottle = false;     // leave it now
  bool baseline = false;       // self-sampling: sample now and restart the sampling period
  bool stop_sampling = false;  // self-sampling: no more periodic samples
  bool resume = false;         // self-sampling: THR -> ON, a period owed meanwhile runs now
  std::optional<TimeNs> activation_delay_ns;  // entering THR: time since the causing sample
};

class NrtDriver {
 public:
  explicit NrtDriver(Sampling sampling, TimeNs watchdog_ns = 0);

  // `cause`: measurement time of the sample that made the controller send the command, or -1.
  NrtEffects command(TimeNs t, Command command, TimeNs cause);
  void heard(TimeNs t);
  // When the watchdog fires if nothing is heard before; nullopt when OFF or without watchdog.
  std::optional<TimeNs> watchdog_deadline() const;
  // The deadline passed: back to nominal, as if OFF had arrived.
  NrtEffects watchdog(TimeNs t);
  // End of the run: a throttle interval still open is closed at t.
  void finish(TimeNs t);

  NodeState state() const { return node_.state(); }
  Sampling sampling() const { return node_.sampling(); }
  std::uint64_t throttles() const { return throttles_; }
  TimeNs throttled_ns() const { return throttled_ns_; }
  std::uint64_t watchdog_fired() const { return watchdog_fired_; }

 private:
  NrtNode node_;
  TimeNs watchdog_ns_;
  TimeNs last_heard_ = 0;
  TimeNs thr_since_ = -1;
  std::uint64_t throttles_ = 0;
  TimeNs throttled_ns_ = 0;
  std::uint64_t watchdog_fired_ = 0;
};

class SampleSchedule {
 public:
  explicit SampleSchedule(TimeNs period_ns);

  // A baseline sample is taken at t: the next period ends at t + period, nothing is owed.
  void restart(TimeNs t);
  void stop();
  // The period ended (t >= next()): advances the grid. Returns true when the host samples now;
  // false (the host cannot: busy or not ON) makes the sample owed.
  bool elapsed(TimeNs t, bool can_sample);
  // A sample requested while the host is busy: owed.
  void defer() { owed_ = true; }
  // The host can sample again: whether a sample is owed (and clears it).
  bool take_owed();
  std::optional<TimeNs> next() const { return next_; }
  TimeNs period_ns() const { return period_ns_; }

 private:
  TimeNs period_ns_;
  std::optional<TimeNs> next_;
  bool owed_ = false;
};

}  // namespace rosguard

#include "engine/nrt_driver.h"

#include "core/error.h"

namespace rosguard {

NrtDriver::NrtDriver(Sampling sampling, TimeNs watchdog_ns)
    : node_(sampling), watchdog_ns_(watchdog_ns) {}

NrtEffects NrtDriver::command(TimeNs t, Command command, TimeNs cause) {
  NrtEffects fx;
  fx.transition = node_.apply(command);
  const Transition& tr = fx.transition;
  if (tr.to == NodeState::Thr && tr.from != NodeState::Thr) {
    fx.throttle = true;
    thr_since_ = t;
    ++throttles_;
    if (cause >= 0) fx.activation_delay_ns = t - cause;
  }
  if (tr.from == NodeState::Thr && tr.to != NodeState::Thr) {
    fx.unthrottle = true;
    throttled_ns_ += t - thr_since_;
    thr_since_ = -1;
  }
  if (node_.sampling() != Sampling::Self) return fx;
  if (command == Command::On && tr.to == NodeState::On)
    fx.baseline = true;  // a new activation: its baseline now, then one every period
  else if (tr.to == NodeState::Off)
    fx.stop_sampling = true;
  else if (tr.from == NodeState::Thr && tr.to == NodeState::On)
    fx.resume = true;
  return fx;
}

void NrtDriver::heard(TimeNs t) {
  last_heard_ = t;
}

std::optional<TimeNs> NrtDriver::watchdog_deadline() const {
  if (watchdog_ns_ <= 0 || node_.state() == NodeState::Off) return std::nullopt;
  return last_heard_ + watchdog_ns_;
}

NrtEffects NrtDriver::watchdog(TimeNs t) {
  ++watchdog_fired_;
  return command(t, Command::Off, -1);
}

void NrtDriver::finish(TimeNs t) {
  if (thr_since_ < 0) return;
  throttled_ns_ += t - thr_since_;
  thr_since_ = -1;
}

SampleSchedule::SampleSchedule(TimeNs period_ns) : period_ns_(period_ns) {
  if (period_ns_ <= 0) throw ContractError("the sampling period must be positive");
}

void SampleSchedule::restart(TimeNs t) {
  next_ = t + period_ns_;
  owed_ = false;
}

void SampleSchedule::stop() {
  next_.reset();
  owed_ = false;
}

bool SampleSchedule::elapsed(TimeNs t, bool can_sample) {
  if (!next_ || t < *next_) return false;
  TimeNs next = *next_ + period_ns_;
  if (next <= t) next += ((t - next) / period_ns_ + 1) * period_ns_;  // stay on the grid
  next_ = next;
  if (!can_sample) owed_ = true;
  return can_sample;
}

bool SampleSchedule::take_owed() {
  const bool owed = owed_;
  owed_ = false;
  return owed;
}

}  // namespace rosguard

#include "engine/controller_driver.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"

namespace rosguard {

void DriverOutput::clear() {
  commands.clear();
  reads.clear();
  keepalives.clear();
  rearm.clear();
  events.clear();
}

ControllerDriver::ControllerDriver(ControllerDriverConfig config,
                                   std::unique_ptr<Regulator> regulator, EntityMeter* meter)
    : cfg_(config), regulator_(std::move(regulator)), meter_(meter) {
  if (!regulator_) throw ContractError("a controller driver needs a regulator");
  if (cfg_.sampling_period_ns <= 0) throw ContractError("the sampling period must be positive");
  const std::size_t n = regulator_->entity_count();
  at_activation_.assign(n, {});
  window_bytes_start_.assign(n, 0.0);
  totals_.active.assign(n, {});
  commands_.reserve(16);
}

// The controller (or, under overflow sampling, the interrupt handler) reads the counters itself:
// everything but self-sampling.
bool ControllerDriver::samples_externally() const {
  return cfg_.sampling != Sampling::Self && regulator_->policy().regulates() &&
         regulator_->entity_count() > 0;
}

bool ControllerDriver::periodic_reads() const {
  return cfg_.sampling == Sampling::External || cfg_.sampling == Sampling::Mmio;
}

void ControllerDriver::rt_signal(TimeNs t, std::size_t rt, bool started, DriverOutput& out) {
  commands_.clear();
  if (started)
    regulator_->rt_started(t, rt, commands_);
  else
    regulator_->rt_finished(t, rt, commands_);
  after_input(t, -1, out);
}

void ControllerDriver::sample(TimeNs t, std::size_t entity, std::span<const CounterValue> counters,
                              std::optional<TimeNs> measured, DriverOutput& out) {
  commands_.clear();
  regulator_->sample(t, entity, counters, commands_, measured);
  pace_read(t);
  if (regulator_->active()) {
    const Account& acc = regulator_->accounts()[regulator_->entity(entity).account];
    if (acc.budget_bytes > 0)
      out.events.push_back(
          {EngineEvent::Kind::BudgetUsed, t, entity, 100.0 * acc.used_bytes / acc.budget_bytes});
  }
  after_input(t, measured.value_or(-1), out);
}

void ControllerDriver::tick(TimeNs t, DriverOutput& out) {
  commands_.clear();
  const auto boundary = regulator_->next_tick();
  regulator_->tick(t, commands_);
  pace_read(t);
  after_input(t, -1, out);
  // Overflow sampling has no periodic reads: each window's usage is measured from a reading at
  // its start (MemGuard's period timer reads its counter), not spread over the time since the
  // last interrupt, most of which the core may have spent throttled in the previous window. Paced
  // reads (max_bytes_per_ns) start each window from a reading too, for the same reason.
  const bool paced = cfg_.max_bytes_per_ns > 0.0 && periodic_reads();
  if ((cfg_.sampling == Sampling::Overflow || paced) && boundary && t >= *boundary &&
      regulator_->active())
    for (std::size_t e = 0; e < regulator_->entity_count(); ++e)
      out.reads.push_back(e);
}

// Publishes what the regulator decided, then follows the activation edges it caused.
void ControllerDriver::after_input(TimeNs t, TimeNs cause, DriverOutput& out) {
  for (const CommandOut& c : commands_)
    out.commands.push_back({t, c.entity, c.command, cause});
  commands_.clear();
  if (!was_active_ && regulator_->active()) activation_begin(t, out);
  if (was_active_ && !regulator_->active()) activation_end(t, out);
  if (cfg_.sampling == Sampling::Overflow && regulator_->policy().regulates())
    for (std::size_t e = 0; e < regulator_->entity_count(); ++e)
      out.rearm.push_back(e);
  if (cfg_.keepalive_ns <= 0) return;
  bool any_on = false;
  for (std::size_t e = 0; e < regulator_->entity_count(); ++e)
    any_on = any_on || regulator_->entity(e).state != NodeState::Off;
  if (!any_on)
    next_keepalive_.reset();
  else if (!next_keepalive_)
    next_keepalive_ = t;  // the first keep-alive right away
}

void ControllerDriver::activation_begin(TimeNs t, DriverOutput& out) {
  was_active_ = true;
  active_since_ = t;
  ++totals_.activations;
  for (std::size_t e = 0; e < at_activation_.size(); ++e) {
    at_activation_[e] = meter_ ? meter_->read(e, t) : EntityReading{};
    window_bytes_start_[e] = at_activation_[e].bytes;
  }
  window_start_ = t;
  window_index_ = 0;
  out.events.push_back({EngineEvent::Kind::ActivationBegin, t, 0, 0.0});
  if (!regulator_->policy().regulates()) return;
  if (cfg_.record_windows) next_window_ = regulator_->policy().window_end(t);
  // External sampling: the first read (the baseline) right away, then every period.
  if (samples_externally()) next_read_ = t;
}

void ControllerDriver::activation_end(TimeNs t, DriverOutput& out) {
  if (cfg_.record_windows && regulator_->policy().regulates()) {
    const auto end = regulator_->policy().window_end(window_start_);
    close_window(t, !end || *end <= t, out);
  }
  was_active_ = false;
  next_window_.reset();
  next_read_.reset();
  paced_read_.reset();
  totals_.active_ns += t - active_since_;
  for (std::size_t e = 0; e < at_activation_.size(); ++e) {
    const EntityReading now = meter_ ? meter_->read(e, t) : EntityReading{};
    EntityReading& sum = totals_.active[e];
    sum.bytes += now.bytes - at_activation_[e].bytes;
    sum.cycles += now.cycles - at_activation_[e].cycles;
    sum.work += now.work - at_activation_[e].work;
  }
  out.events.push_back({EngineEvent::Kind::ActivationEnd, t, 0, 0.0});
}

void ControllerDriver::close_window(TimeNs t, bool complete, DriverOutput& out) {
  for (std::size_t e = 0; e < window_bytes_start_.size(); ++e) {
    const double bytes = meter_ ? meter_->read(e, t).bytes : 0.0;
    const double used = bytes - window_bytes_start_[e];
    windows_.push_back({e, window_index_, window_start_, t, used, complete});
    out.events.push_back({EngineEvent::Kind::WindowClosed, t, e, used});
    window_bytes_start_[e] = bytes;
  }
  window_start_ = t;
  ++window_index_;
}

std::optional<TimeNs> ControllerDriver::next_read() const {
  if (paced_read_ && (!next_read_ || *paced_read_ < *next_read_)) return paced_read_;
  return next_read_;
}

// The earliest time an ON entity could have spent what its account (or the global cap) has left
// at max_bytes_per_ns per entity drawing on it; none while nothing can run out.
void ControllerDriver::pace_read(TimeNs t) {
  paced_read_.reset();
  if (cfg_.max_bytes_per_ns <= 0.0 || !next_read_ || !periodic_reads()) return;
  const GlobalAccount& g = regulator_->global();
  if (g.released || g.capped) return;
  std::vector<std::size_t> drawing(regulator_->accounts().size(), 0);
  std::size_t on = 0;
  for (std::size_t e = 0; e < regulator_->entity_count(); ++e)
    if (regulator_->entity(e).state == NodeState::On) {
      ++drawing[regulator_->entity(e).account];
      ++on;
    }
  double ns = std::isfinite(g.cap_bytes) && on > 0
                  ? (g.cap_bytes - g.used_bytes) / (cfg_.max_bytes_per_ns * static_cast<double>(on))
                  : std::numeric_limits<double>::infinity();
  for (std::size_t a = 0; a < drawing.size(); ++a) {
    const Account& acc = regulator_->accounts()[a];
    if (drawing[a] == 0 || acc.throttled || !std::isfinite(acc.budget_bytes)) continue;
    ns = std::min(ns, (acc.budget_bytes - acc.used_bytes) /
                          (cfg_.max_bytes_per_ns * static_cast<double>(drawing[a])));
  }
  if (!std::isfinite(ns)) return;
  const TimeNs at = t + std::max<TimeNs>(kMinPacedReadNs, static_cast<TimeNs>(std::ceil(ns)));
  if (at < *next_read_) paced_read_ = at;
}

void ControllerDriver::read_due(TimeNs t, DriverOutput& out) {
  const bool paced = paced_read_ && t >= *paced_read_;
  if (!paced && (!next_read_ || t < *next_read_)) return;
  paced_read_.reset();
  for (std::size_t e = 0; e < regulator_->entity_count(); ++e)
    out.reads.push_back(e);
  if (t < *next_read_) return;  // a paced read: the periodic grid goes on
  if (!periodic_reads()) {      // overflow sampling: the baseline only
    next_read_.reset();
    return;
  }
  // A fixed grid from the activation; periods a late host missed are skipped, not made up.
  const TimeNs p = cfg_.sampling_period_ns;
  TimeNs next = *next_read_ + p;
  if (next <= t) next += ((t - next) / p + 1) * p;
  next_read_ = next;
}

void ControllerDriver::window_due(TimeNs t, DriverOutput& out) {
  if (!next_window_ || t < *next_window_) return;
  close_window(t, true, out);
  next_window_ = regulator_->policy().window_end(t);
}

void ControllerDriver::keepalive_due(TimeNs t, DriverOutput& out) {
  if (!next_keepalive_ || t < *next_keepalive_) return;
  for (std::size_t e = 0; e < regulator_->entity_count(); ++e)
    if (regulator_->entity(e).state != NodeState::Off) out.keepalives.push_back(e);
  next_keepalive_ = t + cfg_.keepalive_ns;
}

void ControllerDriver::wake(TimeNs t, DriverOutput& out) {
  if (const auto tk = next_tick(); tk && t >= *tk) tick(t, out);
  read_due(t, out);
  window_due(t, out);
  keepalive_due(t, out);
}

void ControllerDriver::finish(TimeNs t, DriverOutput& out) {
  if (was_active_) activation_end(t, out);
}

std::optional<TimeNs> ControllerDriver::next_tick() const {
  if (!regulator_->active()) return std::nullopt;
  return regulator_->next_tick();
}

std::optional<TimeNs> ControllerDriver::next_wakeup() const {
  std::optional<TimeNs> best;
  for (const auto& t : {next_tick(), next_read(), next_window_, next_keepalive_})
    if (t && (!best || *t < *best)) best = t;
  return best;
}

}  // namespace rosguard

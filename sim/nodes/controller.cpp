#include "nodes/controller.h"

#include <string>

#include "core/error.h"

namespace rosguard::sim {

Controller::Controller(const sc_core::sc_module_name& name, ControllerConfig config,
                       std::unique_ptr<Regulator> regulator, const CostParams& costs,
                       std::uint64_t seed, MessageBus& bus, Runtime& rt, Recorder& rec)
    : sc_core::sc_module(name),
      cfg_(std::move(config)),
      driver_({cfg_.sampling, cfg_.sampling_period_ns, 0, true}, std::move(regulator), this),
      callback_cost_(costs.controller_callback, stream_seed(seed, "controller/callback")),
      read_cost_(costs.external_read, stream_seed(seed, "controller/external_read")),
      bus_(bus),
      rt_(rt),
      rec_(rec),
      costs_(costs),
      seed_(seed),
      done_timer_("done", rt, [this](TimeNs t) { stage_done(t); }),
      tick_timer_("tick", rt,
                  [this](TimeNs t) {
                    if (!direct()) {
                      enqueue({Work::Kind::Tick, 0, {}, -1, true, true}, t);
                      return;
                    }
                    out_.clear();
                    driver_.tick(t, out_);
                    const std::vector<std::size_t> reads = out_.reads;
                    handle_output(t);
                    rearm_timers();
                    for (std::size_t e : reads)  // overflow: the period timer's reading
                      direct_sample(e, t, -1);
                  }),
      poll_timer_("poll", rt,
                  [this](TimeNs t) {
                    DriverOutput due;
                    driver_.read_due(t, due);
                    rearm(poll_timer_, driver_.next_read());
                    bool first = true;
                    for (std::size_t e : due.reads)
                      if (cfg_.sampling == Sampling::Overflow) {
                        direct_sample(e, t, -1);  // the baseline: the handler's own read
                      } else {
                        enqueue({Work::Kind::Read, e, {}, -1, true, first}, t);
                        first = false;
                      }
                  }),
      probe_timer_("probe", rt, [this](TimeNs t) {
        DriverOutput due;
        driver_.window_due(t, due);
        rearm(probe_timer_, driver_.next_window());
      }) {
  if (costs.timer_wakeup)
    wakeup_cost_.emplace(*costs.timer_wakeup, stream_seed(seed, "controller/timer_wakeup"));
  if (costs.controller_callback_local)
    local_callback_cost_.emplace(*costs.controller_callback_local,
                                 stream_seed(seed, "controller/callback_local"));
  if (cfg_.sampling == Sampling::Overflow) {
    if (!costs.overflow_irq)
      throw ContractError("overflow sampling needs the platform's costs.overflow_irq_us");
    irq_cost_.emplace(*costs.overflow_irq, stream_seed(seed, "controller/overflow_irq"));
  }
  if (cfg_.sampling == Sampling::Mmio) {
    if (!costs.mmio_poll)
      throw ContractError("mmio sampling needs the platform's costs.mmio_poll_us");
    mmio_cost_.emplace(*costs.mmio_poll, stream_seed(seed, "controller/mmio_poll"));
  }
}

bool Controller::direct() const {
  return cfg_.sampling == Sampling::Overflow || cfg_.sampling == Sampling::Mmio;
}

void Controller::add_entity(ControlledEntity entity) {
  const std::size_t e = entities_.size();
  irq_timers_.push_back(
      std::make_unique<Timer>(("controller_irq" + std::to_string(e)).c_str(), rt_,
                              [this, e](TimeNs t) { direct_sample(e, t, overflow_at_[e]); }));
  overflow_at_.push_back(-1);
  links_.push_back(bus_.add_link());
  latency_.emplace_back(costs_.message_latency_between(cfg_.core, entity.core),
                        stream_seed(seed_, "controller->" + entity.name));
  entities_.push_back(std::move(entity));
}

EntityReading Controller::read(std::size_t entity, TimeNs) {
  const Pmu& p = entities_.at(entity).pmu();
  return {p.l3_accesses() * cfg_.line_bytes, p[PmuEvent::CpuCycles], 0.0};
}

void Controller::enable(std::size_t rt, TimeNs now, int from_core) {
  enqueue({Work::Kind::Enable, rt, {}, -1, from_core == cfg_.core}, now);
}

void Controller::disable(std::size_t rt, TimeNs now, int from_core) {
  enqueue({Work::Kind::Disable, rt, {}, -1, from_core == cfg_.core}, now);
}

void Controller::sample(std::size_t entity, std::vector<CounterValue> counters, TimeNs published,
                        TimeNs now) {
  const bool local = entities_.at(entity).core == cfg_.core;
  enqueue({Work::Kind::Sample, entity, std::move(counters), published, local}, now);
}

TimeNs Controller::callback_cost(const Work& w) {
  return w.local && local_callback_cost_ ? local_callback_cost_->draw_ns()
                                         : callback_cost_.draw_ns();
}

void Controller::enqueue(Work w, TimeNs now) {
  queue_.push_back(std::move(w));
  start_next(now);
}

void Controller::start_next(TimeNs now) {
  if (busy_ || queue_.empty()) return;
  current_ = std::move(queue_.front());
  queue_.pop_front();
  busy_ = true;
  // A timer's wake-up comes first (not for MemPol's polls: a polling loop, no timer).
  const TimeNs wakeup = current_.timer && wakeup_cost_ && !mmio_cost_ ? wakeup_cost_->draw_ns() : 0;
  if (current_.kind == Work::Kind::Read) {
    stage_ = 0;
    read_started_ = now + wakeup;
    spend(now, wakeup + (mmio_cost_ ? mmio_cost_->draw_ns() : read_cost_.draw_ns()));
  } else {
    stage_ = 1;
    spend(now, wakeup + callback_cost(current_));
  }
}

void Controller::spend(TimeNs now, TimeNs cost) {
  if (core_)
    core_->post(Core::Prio::Controller, cost, "controller", [this](TimeNs t) { stage_done(t); });
  else
    done_timer_.set(now + cost);
}

void Controller::stage_done(TimeNs now) {
  if (stage_ == 0) {
    // External sampling: the counters are read now; the control logic follows.
    current_.counters = read_counters(current_.index, now);
    rec_.observe("pmc_callback", now - read_started_);
    current_.origin = now;
    stage_ = 1;
    // A MemPol poll compares and halts within its mmio_poll_us: no callback after it.
    if (!mmio_cost_) {
      spend(now, callback_cost(current_));
      return;
    }
  }
  decide(current_, now);
  busy_ = false;
  start_next(now);
}

std::vector<CounterValue> Controller::read_counters(std::size_t entity, TimeNs now) {
  const Pmu& pmu = entities_.at(entity).pmu();
  std::vector<CounterValue> out;
  out.reserve(cfg_.metric_events.size());
  for (PmuEvent e : cfg_.metric_events)
    out.push_back(pmu.read(e, now));
  return out;
}

void Controller::decide(Work& w, TimeNs now) {
  out_.clear();
  switch (w.kind) {
    case Work::Kind::Enable:
    case Work::Kind::Disable:
      driver_.rt_signal(now, w.index, w.kind == Work::Kind::Enable, out_);
      break;
    case Work::Kind::Sample:
    case Work::Kind::Read:
      // Charged by when the counters were read (published / read), processed now.
      driver_.sample(now, w.index, w.counters,
                     w.origin >= 0 ? std::optional<TimeNs>(w.origin) : std::nullopt, out_);
      break;
    case Work::Kind::Tick:
      driver_.tick(now, out_);
      break;
  }
  handle_output(now);
  rearm_timers();
}

void Controller::rearm_timers() {
  // Same order as the timers were armed before the engine existed: probe, poll, tick.
  rearm(probe_timer_, driver_.next_window());
  rearm(poll_timer_, driver_.next_read());
  rearm(tick_timer_, driver_.next_tick());
}

// Overflow sampling: the handler on the entity's core reads its counters (at a crossing, or the
// baseline at ON) and the engine decides at once; `cause` is the crossing (-1: none).
void Controller::direct_sample(std::size_t entity, TimeNs now, TimeNs cause) {
  out_.clear();
  const std::vector<CounterValue> counters = read_counters(entity, now);
  driver_.sample(now, entity, counters, now, out_);
  if (cause >= 0)
    for (DriverCommand& c : out_.commands)
      if (c.command == Command::Thr) c.cause = cause;
  handle_output(now, true);
  rearm_timers();
}

void Controller::arm_overflow(std::size_t entity) {
  ControlledEntity& ent = entities_.at(entity);
  if (!ent.core_model) throw ContractError("overflow sampling needs the entity's core");
  if (irq_timers_[entity]->pending()) return;  // its handler re-arms when it has run
  const auto limits = driver_.regulator().overflow_limits(entity);
  if (limits.empty()) {
    ent.core_model->disarm_overflow();
    return;
  }
  std::vector<Core::OverflowLimit> arms;
  for (const OverflowLimit& l : limits) {
    Core::OverflowLimit a;
    for (std::size_t i = 0; i < l.bytes_per_count.size(); ++i)
      a.bytes_per_count[static_cast<std::size_t>(cfg_.metric_events.at(i))] += l.bytes_per_count[i];
    a.at_bytes = l.at_bytes;
    arms.push_back(a);
  }
  ent.core_model->arm_overflow(std::move(arms),
                               [this, entity](TimeNs t) { overflow_hit(entity, t); });
}

// The PMU overflowed: the core works on until the interrupt's handler runs.
void Controller::overflow_hit(std::size_t entity, TimeNs now) {
  overflow_at_[entity] = now;
  irq_timers_[entity]->set(now + irq_cost_->draw_ns());
  rec_.observe("overflow_irq", irq_timers_[entity]->when() - now);
}

void Controller::handle_output(TimeNs now, bool from_handler) {
  for (const EngineEvent& ev : out_.events)
    if (ev.kind == EngineEvent::Kind::BudgetUsed && rec_.trace)
      rec_.trace->counter(now, cfg_.core, entities_[ev.entity].name + " budget_used_pct", ev.value);
  for (const DriverCommand& c : out_.commands) {
    const ControlledEntity& target = entities_[c.entity];
    if (rec_.trace)
      rec_.trace->instant(now, cfg_.core, "controller",
                          std::string(to_string(c.command)) + " -> " + target.name);
    // Mmio: the controller halts / resumes the core itself; overflow: a THR from the handler
    // takes hold on its own core at once, anything else one interrupt later.
    if (cfg_.sampling == Sampling::Mmio ||
        (from_handler && cfg_.sampling == Sampling::Overflow && c.command == Command::Thr)) {
      target.deliver(c.command, c.cause);
      continue;
    }
    // With a local callback cost, the switch to a node on the controller's core is in it.
    const TimeNs latency = cfg_.sampling == Sampling::Overflow ? irq_cost_->draw_ns()
                           : local_callback_cost_ && target.core == cfg_.core
                               ? 0
                               : latency_[c.entity].draw_ns();
    bus_.send(links_[c.entity], now, latency,
              [deliver = target.deliver, cmd = c.command, cause = c.cause](TimeNs) {
                deliver(cmd, cause);
              });
  }
  for (std::size_t e : out_.rearm)
    arm_overflow(e);
  for (const EngineEvent& ev : out_.events)
    if (ev.kind == EngineEvent::Kind::ActivationEnd && on_inactive_) on_inactive_(now);
}

void Controller::rearm(Timer& timer, std::optional<TimeNs> when) {
  if (!when)
    timer.cancel();
  else if (!timer.pending() || timer.when() != *when)
    timer.set(*when);
}

void Controller::finish(TimeNs now) {
  DriverOutput last;
  driver_.finish(now, last);
}

}  // namespace rosguard::sim

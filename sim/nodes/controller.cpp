#include "nodes/controller.h"

#include <string>

#include "metric/metric.h"
#include "nodes/nrt_node.h"

namespace rosguard::sim {

Controller::Controller(const sc_core::sc_module_name& name, ControllerConfig config,
                       std::unique_ptr<Regulator> regulator, const CostParams& costs,
                       std::uint64_t seed, MessageBus& bus, Runtime& rt, Recorder& rec)
    : sc_core::sc_module(name),
      cfg_(std::move(config)),
      regulator_(std::move(regulator)),
      callback_cost_(costs.controller_callback, stream_seed(seed, "controller/callback")),
      read_cost_(costs.external_read, stream_seed(seed, "controller/external_read")),
      bus_(bus),
      rt_(rt),
      rec_(rec),
      message_latency_(costs.message_latency),
      seed_(seed),
      done_timer_("done", rt, [this](TimeNs t) { stage_done(t); }),
      tick_timer_("tick", rt,
                  [this](TimeNs t) {
                    enqueue({Work::Kind::Tick, 0, {}, -1}, t);
                  }),
      poll_timer_("poll", rt,
                  [this](TimeNs t) {
                    poll_timer_.set(t + cfg_.sampling_period_ns);
                    for (std::size_t e = 0; e < nrt_.size(); ++e)
                      enqueue({Work::Kind::Read, e, {}, -1}, t);
                  }),
      probe_timer_("probe", rt, [this](TimeNs t) { window_probe(t, true); }) {
  out_.reserve(16);
}

void Controller::add_nrt(NrtNodeModel* node) {
  nrt_.push_back(node);
  links_.push_back(bus_.add_link());
  latency_.emplace_back(message_latency_, stream_seed(seed_, "controller->" + node->config().name));
  active_start_.emplace_back();
  active_l3_.push_back(0.0);
  active_cycles_.push_back(0.0);
  window_l3_.push_back(0.0);
  last_sample_l3_.push_back(0.0);
  last_sample_cycles_.push_back(0.0);
}

void Controller::enable(std::size_t rt, TimeNs now) {
  enqueue({Work::Kind::Enable, rt, {}, -1}, now);
}

void Controller::disable(std::size_t rt, TimeNs now) {
  enqueue({Work::Kind::Disable, rt, {}, -1}, now);
}

void Controller::sample(std::size_t entity, std::vector<CounterValue> counters, TimeNs published,
                        TimeNs now) {
  enqueue({Work::Kind::Sample, entity, std::move(counters), published}, now);
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
  if (current_.kind == Work::Kind::Read) {
    stage_ = 0;
    read_started_ = now;
    done_timer_.set(now + read_cost_.draw_ns());
  } else {
    stage_ = 1;
    done_timer_.set(now + callback_cost_.draw_ns());
  }
}

void Controller::stage_done(TimeNs now) {
  if (stage_ == 0) {
    // External sampling: the counters are read now; the control logic follows.
    current_.counters = read_counters(current_.index, now);
    rec_.observe("pmc_callback", now - read_started_);
    current_.origin = now;
    stage_ = 1;
    done_timer_.set(now + callback_cost_.draw_ns());
    return;
  }
  decide(current_, now);
  busy_ = false;
  start_next(now);
}

std::vector<CounterValue> Controller::read_counters(std::size_t entity, TimeNs now) {
  const Pmu& pmu = nrt_[entity]->core().pmu();
  std::vector<CounterValue> out;
  out.reserve(cfg_.metric_events.size());
  for (PmuEvent e : cfg_.metric_events)
    out.push_back(pmu.read(e, now));
  return out;
}

void Controller::decide(Work& w, TimeNs now) {
  Regulator& reg = *regulator_;
  switch (w.kind) {
    case Work::Kind::Enable:
      reg.rt_started(now, w.index, out_);
      break;
    case Work::Kind::Disable:
      reg.rt_finished(now, w.index, out_);
      break;
    case Work::Kind::Sample:
    case Work::Kind::Read:
      // Charged by when the counters were read (published / read), processed now.
      reg.sample(now, w.index, w.counters, out_,
                 w.origin >= 0 ? std::optional<TimeNs>(w.origin) : std::nullopt);
      if (rec_.trace && reg.active()) {
        const auto& acc = reg.accounts()[reg.entity(w.index).account];
        if (acc.budget_bytes > 0)
          rec_.trace->counter(now, cfg_.core, nrt_[w.index]->config().name + " budget_used_pct",
                              100.0 * acc.used_bytes / acc.budget_bytes);
      }
      break;
    case Work::Kind::Tick:
      reg.tick(now, out_);
      break;
  }
  publish(w.kind == Work::Kind::Sample || w.kind == Work::Kind::Read ? w.origin : -1, now);
  if (!was_active_ && reg.active()) activation_begin(now);
  if (was_active_ && !reg.active()) activation_end(now);
  rearm_tick();
}

void Controller::publish(TimeNs origin, TimeNs now) {
  for (const CommandOut& c : out_) {
    NrtNodeModel* node = nrt_[c.entity];
    const Command cmd = c.command;
    if (rec_.trace)
      rec_.trace->instant(now, cfg_.core, "controller",
                          std::string(to_string(cmd)) + " -> " + node->config().name);
    bus_.send(links_[c.entity], now, latency_[c.entity].draw_ns(),
              [node, cmd, origin](TimeNs) { node->on_command(cmd, origin); });
  }
  out_.clear();
}

void Controller::rearm_tick() {
  const auto next = regulator_->next_tick();
  if (!next || !regulator_->active()) {
    tick_timer_.cancel();
  } else if (!tick_timer_.pending() || tick_timer_.when() != *next) {
    tick_timer_.set(*next);
  }
}

void Controller::activation_begin(TimeNs now) {
  was_active_ = true;
  active_since_ = now;
  ++activations_;
  for (std::size_t e = 0; e < nrt_.size(); ++e) {
    active_start_[e] = nrt_[e]->core().pmu();
    window_l3_[e] = active_start_[e].l3_accesses();
  }
  window_start_ = now;
  window_index_ = 0;
  if (regulator_->policy().regulates()) {
    if (cfg_.periodic_windows) probe_timer_.set(now + cfg_.regulation_period_ns);
    // External sampling: the first read (the baseline) right away, then every period.
    if (cfg_.sampling == Sampling::External && !nrt_.empty()) poll_timer_.set(now);
  }
}

void Controller::window_probe(TimeNs now, bool complete) {
  for (std::size_t e = 0; e < nrt_.size(); ++e) {
    const double l3 = nrt_[e]->core().pmu().l3_accesses();
    rec_.windows.push_back(
        {e, window_index_, window_start_, now, (l3 - window_l3_[e]) * cfg_.line_bytes, complete});
    window_l3_[e] = l3;
  }
  window_start_ = now;
  ++window_index_;
  if (was_active_ && cfg_.periodic_windows) probe_timer_.set(now + cfg_.regulation_period_ns);
}

void Controller::activation_end(TimeNs now) {
  if (regulator_->policy().regulates())
    window_probe(now, now - window_start_ >= cfg_.regulation_period_ns);
  was_active_ = false;
  probe_timer_.cancel();
  poll_timer_.cancel();
  active_ns_ += now - active_since_;
  for (std::size_t e = 0; e < nrt_.size(); ++e) {
    const Pmu& p = nrt_[e]->core().pmu();
    active_l3_[e] += p.l3_accesses() - active_start_[e].l3_accesses();
    active_cycles_[e] += p[PmuEvent::CpuCycles] - active_start_[e][PmuEvent::CpuCycles];
  }
  if (on_inactive_) on_inactive_(now);
}

void Controller::finish(TimeNs now) {
  if (was_active_) activation_end(now);
}

}  // namespace rosguard::sim

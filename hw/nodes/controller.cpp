#include "hw/nodes/controller.h"

#include <algorithm>

#include "core/error.h"
#include "hw/common/clock.h"

namespace rosguard::hw {

Controller::Controller(ControllerConfig config, std::unique_ptr<Regulator> regulator,
                       Topic<RtEventMsg>& rt_topic, Topic<SampleMsg>& samples,
                       std::vector<Topic<ControlMsg>*> controls, std::vector<CounterGroup*> groups,
                       WindowHook on_window, Waker& engine_waker, RtThread::ErrorHandler on_error,
                       TimeNs origin)
    : cfg_(std::move(config)),
      reg_(std::move(regulator)),
      rt_topic_(rt_topic),
      samples_(samples),
      controls_(std::move(controls)),
      groups_(std::move(groups)),
      on_window_(std::move(on_window)),
      engine_waker_(engine_waker),
      on_error_(std::move(on_error)),
      origin_(origin),
      trace_(cfg_.trace) {
  rt_sub_ = rt_topic_.subscribe(waker_);
  sample_sub_ = samples_.subscribe(waker_);
  for (auto* c : controls_)
    control_pubs_.push_back(c->add_publisher());
  out_.reserve(64);
  reads_us_.reserve(1 << 16);
  for (std::size_t e = 0; e < controls_.size(); ++e)
    counter_names_.push_back("nrt" + std::to_string(e) + " MB/s");
  last_sample_t_.assign(controls_.size(), 0);
  last_bytes_.assign(controls_.size(), 0.0);
}

Controller::~Controller() {
  shutdown();
}

void Controller::start() {
  thread_ = std::make_unique<RtThread>(
      ThreadSpec{"controller", cfg_.core, cfg_.sched, prio::kController}, [this] { main(); },
      on_error_);
}

void Controller::shutdown() {
  if (shut_) return;
  shut_ = true;
  stop_.store(true, std::memory_order_release);
  waker_.notify();
  if (thread_) thread_->join();
}

void Controller::send(const Commands& out, TimeNs cause) {
  const TimeNs now = now_ns();
  for (const CommandOut& c : out) {
    ControlMsg m{ControlMsg::Kind::Command, c.command, now, cause};
    if (!controls_[c.entity]->publish(control_pubs_[c.entity], m))
      throw RunError("control topic of nRT entity " + std::to_string(c.entity) +
                     " is full: a command was lost");
    ++commands_;
    trace_.instant(now - origin_, cfg_.entity_cores[c.entity], nullptr,
                   to_string(c.command).data());
  }
}

void Controller::sample_entity(std::size_t e, TimeNs measured, const CounterValue* values,
                               TimeNs cause) {
  // Processed now (monotonic for the regulator); charged by when it was measured.
  const TimeNs t = std::max({now_ns(), measured, last_t_});
  last_t_ = t;
  out_.clear();
  const double before = reg_->entity(e).bytes_active;
  reg_->sample(t, e, std::span(values, cfg_.metric_events), out_, measured);
  if (cfg_.trace) {
    const double bytes = reg_->entity(e).bytes_active - before;
    if (last_sample_t_[e] > 0 && measured > last_sample_t_[e] && bytes > 0.0)
      trace_.counter(
          measured - origin_, cfg_.entity_cores[e], counter_names_[e].c_str(),
          bytes / kBytesPerMb / (static_cast<double>(measured - last_sample_t_[e]) / 1e9));
    last_sample_t_[e] = measured;
  }
  send(out_, cause);
}

void Controller::external_round() {
  std::array<CounterValue, kMaxGroupEvents> v{};
  for (std::size_t e = 0; e < groups_.size(); ++e) {
    const TimeNs t0 = now_ns();
    groups_[e]->read(std::span(v.data(), cfg_.group_sizes[e]));
    const TimeNs t1 = now_ns();
    reads_us_.push_back(ns_to_us(t1 - t0));
    sample_entity(e, t1, v.data(), t1);
  }
}

void Controller::main() {
  const bool external = cfg_.sampling == Sampling::External;
  TimeNs next_sample = -1, next_keepalive = -1, first_activation = -1;
  while (!stop_.load(std::memory_order_acquire)) {
    const auto epoch = waker_.epoch();
    if (cfg_.fail_after_ns >= 0 && first_activation >= 0 &&
        now_ns() - first_activation >= cfg_.fail_after_ns) {
      fault_t_ = now_ns();
      faulted_.store(true, std::memory_order_release);
      engine_waker_.notify();
      return;  // silent from now on: no OFF, no keepalive
    }
    bool busy = false;
    RtEventMsg ev;
    while (rt_topic_.take(rt_sub_, ev)) {
      busy = true;
      const TimeNs t = std::max(now_ns(), last_t_);
      last_t_ = t;
      out_.clear();
      const bool was_active = reg_->active();
      if (ev.started) {
        reg_->rt_started(t, ev.rt, out_);
      } else {
        reg_->rt_finished(t, ev.rt, out_);
      }
      if (!was_active && reg_->active()) {
        if (first_activation < 0) first_activation = t;
        if (on_window_) on_window_(true, t);
        send(out_, t);
        trace_.instant(t - origin_, cfg_.core, nullptr, "activation");
        opened_.fetch_add(1, std::memory_order_acq_rel);
        engine_waker_.notify();
        if (external && reg_->policy().regulates()) {
          external_round();  // the baselines, as soon as the entities are ON
          next_sample = now_ns() + cfg_.sampling_period_ns;
        }
      } else if (was_active && !reg_->active()) {
        send(out_, t);
        if (on_window_) on_window_(false, t);
        trace_.instant(t - origin_, cfg_.core, nullptr, "deactivation");
        next_sample = -1;
        closed_.fetch_add(1, std::memory_order_acq_rel);
        engine_waker_.notify();
      } else {
        send(out_, t);
      }
      rt_events_.fetch_add(1, std::memory_order_acq_rel);
      engine_waker_.notify();
    }
    SampleMsg s;
    while (samples_.take(sample_sub_, s)) {
      busy = true;
      sample_entity(s.entity, s.t_published, s.counters.data(), s.t_published);
    }
    TimeNs now = now_ns();
    if (external && next_sample >= 0 && now >= next_sample) {
      external_round();
      next_sample += cfg_.sampling_period_ns;
      now = now_ns();
      if (next_sample <= now) next_sample = now + cfg_.sampling_period_ns;
      busy = true;
    }
    if (auto tick = reg_->next_tick(); tick && now >= *tick) {
      const TimeNs t = std::max(now, last_t_);
      last_t_ = t;
      out_.clear();
      reg_->tick(t, out_);
      send(out_, t);
      busy = true;
    }
    bool any_on = false;
    for (std::size_t e = 0; e < reg_->entity_count(); ++e)
      any_on = any_on || reg_->entity(e).state != NodeState::Off;
    if (any_on && (next_keepalive < 0 || now >= next_keepalive)) {
      for (std::size_t e = 0; e < reg_->entity_count(); ++e)
        if (reg_->entity(e).state != NodeState::Off)
          controls_[e]->publish(control_pubs_[e],
                                {ControlMsg::Kind::Keepalive, Command::On, now, 0});
      next_keepalive = now + cfg_.keepalive_ns;
    }
    if (!any_on) next_keepalive = -1;
    if (busy) continue;
    TimeNs deadline = -1;
    const auto earliest = [&deadline](TimeNs t) {
      if (t >= 0 && (deadline < 0 || t < deadline)) deadline = t;
    };
    earliest(next_sample);
    if (auto tick = reg_->next_tick()) earliest(*tick);
    earliest(next_keepalive);
    if (cfg_.fail_after_ns >= 0 && first_activation >= 0)
      earliest(first_activation + cfg_.fail_after_ns);
    waker_.wait(epoch, deadline);
  }
}

}  // namespace rosguard::hw

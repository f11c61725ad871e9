#include "hw/nodes/controller.h"

#include <algorithm>

#include "core/error.h"

namespace rosguard::hw {

Controller::Controller(ControllerConfig config, std::unique_ptr<Regulator> regulator,
                       Topic<RtEventMsg>& rt_topic, Topic<SampleMsg>& samples,
                       std::vector<Topic<ControlMsg>*> controls, EntityMeter* meter,
                       Waker& engine_waker, RtThread::ErrorHandler on_error, TimeNs origin)
    : cfg_(std::move(config)),
      driver_(
          {cfg_.sampling, cfg_.sampling_period_ns, cfg_.keepalive_ns, false, cfg_.max_bytes_per_ns},
          std::move(regulator), meter),
      rt_topic_(rt_topic),
      samples_(samples),
      controls_(std::move(controls)),
      engine_waker_(engine_waker),
      on_error_(std::move(on_error)),
      origin_(origin),
      trace_(cfg_.trace) {
  rt_sub_ = rt_topic_.subscribe(waker_);
  sample_sub_ = samples_.subscribe(waker_);
  for (auto* c : controls_)
    control_pubs_.push_back(c->add_publisher());
  out_.commands.reserve(64);
  reads_us_.reserve(1 << 16);
  for (std::size_t e = 0; e < controls_.size(); ++e)
    counter_names_.push_back("nrt" + std::to_string(e) + " MB/s");
  last_sample_t_.assign(controls_.size(), 0);
  finished_ = std::make_unique<std::atomic<int>[]>(cfg_.rt_count);
  signals_.reserve(1024);
}

Controller::~Controller() {
  shutdown();
  delete pending_policy_.exchange(nullptr);
}

void Controller::post_policy(std::unique_ptr<Policy> policy) {
  delete pending_policy_.exchange(policy.release(), std::memory_order_acq_rel);
  waker_.notify();
}

void Controller::note(const ControllerNote& n) {
  if (cfg_.notes && !cfg_.notes->push(n)) ++notes_dropped_;
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
  overflow_.clear();  // their owner is gone: no signal can reach a handler any more
}

void Controller::set_overflow(std::vector<std::unique_ptr<OverflowCounters>> counters) {
  if (counters.size() > controls_.size())
    throw ContractError("overflow counters for more entities than the controller has");
  overflow_ = std::move(counters);
  overflow_.resize(controls_.size());
  armed_.assign(controls_.size(), {});
  sink_ = std::make_unique<OverflowSink>(controls_.size(), waker_);
}

// Monotonic for the driver, whatever the threads' clocks read.
TimeNs Controller::now() {
  last_t_ = std::max(cfg_.clock(), last_t_);
  return last_t_;
}

void Controller::send(const DriverCommand& c) {
  const TimeNs now = cfg_.clock();
  ControlMsg m{ControlMsg::Kind::Command, c.command, c.cause};
  if (!controls_[c.entity]->publish(control_pubs_[c.entity], m))
    throw RunError("control topic of nRT entity " + std::to_string(c.entity) +
                   " is full: a command was lost");
  trace_.instant(now - origin_, cfg_.entity_cores[c.entity], nullptr, to_string(c.command).data());
  if (c.command == Command::Thr && first_throttle_ < 0) first_throttle_ = now;
  ControllerNote n;
  n.kind = ControllerNote::Kind::Command;
  n.t = now;
  n.entity = c.entity;
  n.command = c.command;
  n.cause = c.cause;
  note(n);
}

// Publishes what the driver decided, and reads the counters it asked for (each read is a
// sample, handled in turn).
void Controller::handle() {
  while (true) {
    for (const DriverCommand& c : out_.commands)
      send(c);
    for (const EngineEvent& ev : out_.events) {
      if (cfg_.notes) {
        ControllerNote n;
        n.t = ev.t;
        n.entity = ev.entity;
        n.value = ev.value;
        switch (ev.kind) {
          case EngineEvent::Kind::ActivationBegin:
          case EngineEvent::Kind::ActivationEnd:
            n.kind = ControllerNote::Kind::Activation;
            n.active = ev.kind == EngineEvent::Kind::ActivationBegin;
            break;
          case EngineEvent::Kind::WindowClosed:
            n.kind = ControllerNote::Kind::WindowClosed;
            break;
          case EngineEvent::Kind::BudgetUsed:
            n.kind = ControllerNote::Kind::Budget;
            break;
        }
        note(n);
      }
      if (ev.kind == EngineEvent::Kind::ActivationBegin) {
        trace_.instant(ev.t - origin_, cfg_.core, nullptr, "activation");
        opened_.fetch_add(1, std::memory_order_acq_rel);
        engine_waker_.notify();
      } else if (ev.kind == EngineEvent::Kind::ActivationEnd) {
        trace_.instant(ev.t - origin_, cfg_.core, nullptr, "deactivation");
      }
    }
    for (std::size_t e : out_.keepalives)
      controls_[e]->publish(control_pubs_[e], {ControlMsg::Kind::Keepalive, Command::On, 0});
    std::vector<std::size_t> reads = out_.reads;
    const std::vector<std::size_t> rearm = out_.rearm;
    out_.clear();
    for (std::size_t e : rearm)
      if (!arm_overflow(e)) reads.push_back(e);  // over a limit already: read it now
    if (reads.empty()) return;
    read_entities(reads);
  }
}

// Overflow sampling: arms entity e's counters for its limits (when they changed or the last arm
// was taken by a signal). False when a limit is exceeded already: the caller reads e now.
bool Controller::arm_overflow(std::size_t e) {
  if (e >= overflow_.size() || !overflow_[e] || e >= groups_.size()) return true;
  Armed& a = armed_[e];
  std::vector<OverflowLimit> limits = driver_.regulator().overflow_limits(e);
  if (limits.empty()) {
    if (a.armed) overflow_[e]->disarm();
    a = {};
    return true;
  }
  if (a.armed && limits == a.limits) return true;
  // The counts now: the counter's period runs from here.
  std::array<CounterValue, kMaxGroupEvents> v{};
  groups_[e]->read(std::span(v.data(), cfg_.group_sizes[e]));
  // The split follows each event's counts since the last arm (kept across a spent arm).
  const OverflowArm arm =
      overflow_arm(limits, std::span(v.data(), cfg_.metric_events),
                   a.at.size() == cfg_.metric_events ? std::span<const std::uint64_t>(a.at)
                                                     : std::span<const std::uint64_t>());
  if (arm.due) {
    if (a.armed) overflow_[e]->disarm();
    a = {};
    return false;
  }
  overflow_[e]->arm(arm.periods);
  a.armed = true;
  a.limits = std::move(limits);
  a.periods = overflow_[e]->periods();
  a.at.clear();
  for (std::size_t i = 0; i < cfg_.metric_events; ++i)
    a.at.push_back(v[i].value);
  a.t = cfg_.clock();
  return true;
}

// Overflow sampling: every entity whose counters signalled is read now (its arm is spent).
void Controller::take_overflows(bool& busy) {
  if (!sink_) return;
  for (std::size_t e = 0; e < overflow_.size(); ++e) {
    const OverflowSink::Hit hit = sink_->take(e);
    if (hit.t == 0) continue;
    busy = true;
    read_entities({e}, &hit);
    handle();
  }
}

void Controller::read_entities(const std::vector<std::size_t>& entities,
                               const OverflowSink::Hit* hit) {
  std::array<CounterValue, kMaxGroupEvents> v{};
  for (std::size_t e : entities) {
    if (e >= groups_.size()) continue;  // no group (yet): nothing to read
    const TimeNs t0 = cfg_.clock();
    groups_[e]->read(std::span(v.data(), cfg_.group_sizes[e]));
    const TimeNs t1 = now();
    if (cfg_.keep_measurements) reads_us_.push_back(ns_to_us(t1 - t0));
    const double before = driver_.regulator().entity(e).bytes_active;
    const std::size_t commands_before = out_.commands.size();
    driver_.sample(t1, e, std::span(v.data(), cfg_.metric_events), t1, out_);
    if (hit) {
      // The throttle is caused by the overflow: its delay counts from the signal.
      bool throttled = false;
      for (std::size_t k = commands_before; k < out_.commands.size(); ++k)
        if (out_.commands[k].command == Command::Thr && out_.commands[k].entity == e) {
          out_.commands[k].cause = hit->t;
          throttled = true;
        }
      Armed& a = armed_[e];
      if (cfg_.keep_measurements && a.armed) {
        OverflowRecord r;
        r.entity = e;
        while (r.event + 1 < a.periods.size() && !((hit->events >> r.event) & 1u))
          ++r.event;
        r.t_armed = a.t;
        r.t_signal = hit->t;
        r.t_read = t1;
        r.period = a.periods[r.event];
        r.at_arm = a.at[r.event];
        r.at_read = v[r.event].value;
        r.throttled = throttled;
        overflows_.push_back(r);
      }
      a.armed = false;  // spent: armed again after this input
    }
    const double bytes = driver_.regulator().entity(e).bytes_active - before;
    trace_bandwidth(e, t1, bytes);
    if (cfg_.notes) {
      ControllerNote n;
      n.kind = ControllerNote::Kind::Sample;
      n.t = t1;
      n.entity = e;
      n.value = bytes;
      n.value2 = static_cast<double>(v[0].value);
      const auto& r = driver_.regulator();
      const auto& acc = r.accounts()[r.entity(e).account];
      n.used = acc.used_bytes;
      n.budget = acc.budget_bytes;
      note(n);
    }
  }
}

void Controller::trace_bandwidth(std::size_t e, TimeNs measured, double bytes) {
  if (!cfg_.trace) return;
  if (last_sample_t_[e] > 0 && measured > last_sample_t_[e] && bytes > 0.0)
    trace_.counter(measured - origin_, cfg_.entity_cores[e], counter_names_[e].c_str(),
                   bytes / kBytesPerMb / (static_cast<double>(measured - last_sample_t_[e]) / 1e9));
  last_sample_t_[e] = measured;
}

bool Controller::serve() {
  bool busy = false;
  if (sink_ && !claimed_) {
    // The thread that serves takes the overflow signals.
    for (std::size_t e = 0; e < overflow_.size(); ++e)
      if (overflow_[e]) overflow_[e]->claim(*sink_, e);
    claimed_ = true;
  }
  if (Policy* p = pending_policy_.exchange(nullptr, std::memory_order_acq_rel)) {
    driver_.set_policy(std::unique_ptr<Policy>(p));
    ControllerNote n;
    n.kind = ControllerNote::Kind::Policy;
    n.t = now();
    note(n);
    busy = true;
  }
  RtEventMsg ev;
  while (rt_topic_.take(rt_sub_, ev)) {
    busy = true;
    const TimeNs t = now();
    if (ev.rt >= cfg_.rt_count)
      throw RunError("an enable / disable signal names RT node " + std::to_string(ev.rt) + " of " +
                     std::to_string(cfg_.rt_count));
    if (cfg_.keep_measurements) signals_.push_back({ev.rt, ev.started, ev.t, t});
    driver_.rt_signal(t, ev.rt, ev.started, out_);
    handle();
    if (!ev.started) finished_[ev.rt].fetch_add(1, std::memory_order_acq_rel);
    rt_events_.fetch_add(1, std::memory_order_acq_rel);
    engine_waker_.notify();
  }
  take_overflows(busy);
  SampleMsg s;
  while (samples_.take(sample_sub_, s)) {
    busy = true;
    // Processed now (monotonic for the regulator); charged by when it was measured.
    last_t_ = std::max(last_t_, s.t_published);
    const TimeNs t = now();
    const double before = driver_.regulator().entity(s.entity).bytes_active;
    driver_.sample(t, s.entity, std::span(s.counters.data(), cfg_.metric_events), s.t_published,
                   out_);
    trace_bandwidth(s.entity, s.t_published,
                    driver_.regulator().entity(s.entity).bytes_active - before);
    handle();
  }
  const TimeNs t = now();
  if (const auto due = driver_.next_wakeup(); due && t >= *due) {
    busy = true;
    driver_.wake(t, out_);
    handle();
  }
  return busy;
}

void Controller::main() {
  while (!stop_.load(std::memory_order_acquire)) {
    const auto epoch = waker_.epoch();
    if (cfg_.fail_after_ns >= 0 && first_throttle_ >= 0 &&
        cfg_.clock() - first_throttle_ >= cfg_.fail_after_ns) {
      faulted_.store(true, std::memory_order_release);
      engine_waker_.notify();
      return;  // silent from now on: no OFF, no keepalive
    }
    const bool busy = serve();
    if (cfg_.notes_waker) cfg_.notes_waker->notify();
    if (busy) continue;
    TimeNs deadline = driver_.next_wakeup().value_or(-1);
    if (cfg_.fail_after_ns >= 0 && first_throttle_ >= 0) {
      const TimeNs fail = first_throttle_ + cfg_.fail_after_ns;
      deadline = deadline < 0 ? fail : std::min(deadline, fail);
    }
    waker_.wait(epoch, deadline);
  }
  for (auto& c : overflow_)
    if (c) c->disarm();
}

}  // namespace rosguard::hw

#include "hw/nodes/controller.h"

#include <algorithm>

#include "core/error.h"

namespace rosguard::hw {

Controller::Controller(ControllerConfig config, std::unique_ptr<Regulator> regulator,
                       Topic<RtEventMsg>& rt_topic, Topic<SampleMsg>& samples,
                       std::vector<Topic<ControlMsg>*> controls, EntityMeter* meter,
                       Waker& engine_waker, RtThread::ErrorHandler on_error, TimeNs origin)
    : cfg_(std::move(config)),
      driver_({cfg_.sampling, cfg_.sampling_period_ns, cfg_.keepalive_ns, false},
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
    const std::vector<std::size_t> reads = out_.reads;
    out_.clear();
    if (reads.empty()) return;
    read_entities(reads);
  }
}

void Controller::read_entities(const std::vector<std::size_t>& entities) {
  std::array<CounterValue, kMaxGroupEvents> v{};
  for (std::size_t e : entities) {
    if (e >= groups_.size()) continue;  // no group (yet): nothing to read
    const TimeNs t0 = cfg_.clock();
    groups_[e]->read(std::span(v.data(), cfg_.group_sizes[e]));
    const TimeNs t1 = now();
    if (cfg_.keep_measurements) reads_us_.push_back(ns_to_us(t1 - t0));
    const double before = driver_.regulator().entity(e).bytes_active;
    driver_.sample(t1, e, std::span(v.data(), cfg_.metric_events), t1, out_);
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
}

}  // namespace rosguard::hw

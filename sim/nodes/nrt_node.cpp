#include "nodes/nrt_node.h"

#include <algorithm>

#include "metric/metric.h"
#include "nodes/controller.h"

namespace rosguard::sim {

NrtNodeModel::NrtNodeModel(const sc_core::sc_module_name& name, NrtNodeConfig config,
                           const WorkloadProfile& profile, const CostParams& costs,
                           std::uint64_t seed, Core& core, MessageBus& bus, Controller& controller,
                           Runtime& rt, Recorder& rec)
    : sc_core::sc_module(name),
      cfg_(std::move(config)),
      profile_(profile),
      core_(core),
      bus_(bus),
      controller_(controller),
      rt_(rt),
      rec_(rec),
      pmc_cost_(costs.pmc_callback, stream_seed(seed, cfg_.name + "/pmc_callback")),
      publish_cost_(costs.publish, stream_seed(seed, cfg_.name + "/publish")),
      cfb_cost_(costs.throttle_activation, stream_seed(seed, cfg_.name + "/cfb")),
      latency_(costs.message_latency_between(core.id(), controller.core()),
               stream_seed(seed, cfg_.name + "->controller")),
      local_message_(costs.local_message_latency && core.id() == controller.core()),
      link_(bus.add_link()),
      driver_(cfg_.sampling),
      schedule_(cfg_.sampling_period_ns),
      run_(profile),
      sample_timer_("sample_timer", rt, [this](TimeNs t) { pmc_timer(t); }),
      state_track_(cfg_.name + " state"),
      freq_hz_(cfg_.freq_hz) {
  if (costs.timer_wakeup)
    wakeup_cost_.emplace(*costs.timer_wakeup, stream_seed(seed, cfg_.name + "/timer_wakeup"));
}

void NrtNodeModel::start(TimeNs now) {
  state_since_ = now;
  run_.restart();
  core_.start_work(&run_, [this](TimeNs t) { work_ended(t); });
}

void NrtNodeModel::work_ended(TimeNs now) {
  if (cfg_.loop) {
    run_.restart();
    return;  // the core picks the restarted run up
  }
  done_ = true;
  finished_at_ = now;
  core_.stop_work();
  if (on_done_) on_done_(now);
}

void NrtNodeModel::on_command(Command command, TimeNs origin) {
  // Overflow (the interrupt handler on this core) and mmio (the controller halts the core
  // through its debug interface) need no CFB callback: the command takes hold as it arrives.
  if (cfg_.sampling == Sampling::Overflow || cfg_.sampling == Sampling::Mmio) {
    apply(command, origin, now_ns());
    return;
  }
  const TimeNs cost = cfb_cost_.draw_ns();
  core_.post(Core::Prio::Cfb, cost, std::string("CFB ") + std::string(to_string(command)),
             [this, command, origin](TimeNs t) { apply(command, origin, t); });
}

void NrtNodeModel::set_state_span(NodeState from, TimeNs now) {
  if (rec_.trace && now > state_since_)
    rec_.trace->span(state_since_, now, core_.id(), state_track_, to_string(from));
  state_since_ = now;
}

void NrtNodeModel::apply(Command command, TimeNs origin, TimeNs now) {
  const NrtEffects fx = driver_.command(now, command, origin);
  const Transition& tr = fx.transition;
  if (tr.changed()) set_state_span(tr.from, now);
  if (fx.throttle) {
    core_.set_throttle(true);
    thr_since_ = now;
    if (fx.activation_delay_ns) rec_.observe("activation_delay", *fx.activation_delay_ns);
  }
  if (fx.unthrottle) {
    core_.set_throttle(false);
    if (rec_.trace) rec_.trace->span(thr_since_, now, core_.id(), cfg_.name + " throttle", "THR");
    thr_since_ = -1;
  }
  if (fx.baseline) {
    schedule_.restart(now);
    sample_timer_.set(*schedule_.next());
    post_pmc();
  } else if (fx.stop_sampling) {
    schedule_.stop();
    sample_timer_.cancel();
  } else if (fx.resume && schedule_.take_owed()) {
    post_pmc();
  }
}

void NrtNodeModel::pmc_timer(TimeNs now) {
  const bool sample = schedule_.elapsed(now, driver_.state() == NodeState::On && !sample_busy_);
  sample_timer_.set(*schedule_.next());
  if (sample) post_pmc(true);
}

void NrtNodeModel::post_pmc(bool timer) {
  if (sample_busy_) {
    schedule_.defer();
    return;
  }
  sample_busy_ = true;
  // Woken by its timer, the PMC thread costs its core the wake-up first.
  const TimeNs cost = pmc_cost_.draw_ns() + (timer && wakeup_cost_ ? wakeup_cost_->draw_ns() : 0);
  core_.post(Core::Prio::Pmc, cost, "PMC", [this, cost](TimeNs t) { pmc_done(cost, t); });
}

void NrtNodeModel::pmc_done(TimeNs cost, TimeNs now) {
  // The counters as the callback read them, handed to the middleware now ("published").
  const Pmu& pmu = core_.pmu();
  std::vector<CounterValue> counters;
  counters.reserve(cfg_.metric_events.size());
  for (PmuEvent e : cfg_.metric_events)
    counters.push_back(pmu.read(e, now));
  rec_.observe("pmc_callback", cost);
  if (rec_.trace) {
    const double l3 = pmu.l3_accesses(), cycles = pmu[PmuEvent::CpuCycles];
    if (have_last_ && cycles > last_cycles_)
      rec_.trace->counter(
          now, core_.id(), "bandwidth_mbps",
          eq1_mbps(cfg_.line_bytes, freq_hz_, l3 - last_l3_, cycles - last_cycles_));
    last_l3_ = l3;
    last_cycles_ = cycles;
    have_last_ = true;
  }
  const TimeNs publish = publish_cost_.draw_ns();
  const TimeNs published = now;
  core_.post(Core::Prio::Pmc, publish, "publish",
             [this, counters = std::move(counters), published, cost, publish](TimeNs t) mutable {
               rec_.observe("sampling_overhead", cost + publish);
               const std::size_t e = cfg_.entity;
               Controller* ctl = &controller_;
               // Between cores the sample leaves as the publish ends; to a controller beside
               // this node (local_message_latency_us, measured from the publish call) as it
               // starts, the controller preempting the publish (here it arrives at the earliest
               // as the publish's core time is over).
               const TimeNs arrival = (local_message_ ? published : t) + latency_.draw_ns();
               bus_.send(link_, t, std::max<TimeNs>(0, arrival - t),
                         [ctl, e, c = std::move(counters), published](TimeNs at) mutable {
                           ctl->sample(e, std::move(c), published, at);
                         });
               sample_busy_ = false;
               if (driver_.state() == NodeState::On && schedule_.take_owed()) post_pmc();
             });
}

void NrtNodeModel::finish(TimeNs now) {
  set_state_span(driver_.state(), now);
  driver_.finish(now);
  if (thr_since_ >= 0) {
    if (rec_.trace) rec_.trace->span(thr_since_, now, core_.id(), cfg_.name + " throttle", "THR");
    thr_since_ = -1;
  }
}

}  // namespace rosguard::sim

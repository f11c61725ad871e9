#include "hw/point_rig.h"

#include <algorithm>
#include <filesystem>
#include <limits>
#include <optional>

#include "core/error.h"
#include "engine/outcome.h"
#include "hw/common/clock.h"
#include "hw/isolation.h"
#include "hw/topic/dds_topic.h"

namespace rosguard::hw {

// What the controller's driver reads of the nRT nodes: the metric's bytes (scaled for
// multiplexing between two reads, accumulated), and completed runs (built-in: units of work /
// units per run; command: processes that exited).
class NodeMeter : public EntityMeter {
 public:
  NodeMeter(std::vector<std::unique_ptr<NrtRunner>>& nrts, const MetricPlan& plan)
      : nrts_(nrts), plan_(plan), metric_(plan.spec), last_(nrts.size()), bytes_(nrts.size()) {}

  EntityReading read(std::size_t e, TimeNs) override {
    NrtRunner& n = *nrts_.at(e);
    std::array<CounterValue, kMaxGroupEvents> v{};
    n.group().read(std::span(v.data(), plan_.group_events.size()));
    const std::size_t k = plan_.metric_events;
    if (last_[e])
      bytes_[e] += metric_.delta_bytes(std::span(last_[e]->data(), k), std::span(v.data(), k));
    last_[e] = v;
    const double runs =
        n.builtin() ? static_cast<double>(n.work().units_done.load(std::memory_order_relaxed)) /
                          static_cast<double>(n.units_per_run())
                    : static_cast<double>(n.completed_runs());
    return {bytes_[e], 0.0, runs};
  }

 private:
  std::vector<std::unique_ptr<NrtRunner>>& nrts_;
  const MetricPlan& plan_;
  Metric metric_;
  std::vector<std::optional<std::array<CounterValue, kMaxGroupEvents>>> last_;
  std::vector<double> bytes_;
};

namespace {

void emit_trace(TraceSink* sink, const TraceLog& log, const char* default_track) {
  if (!sink) return;
  for (const auto& r : log.records()) {
    const std::string_view track = r.track ? std::string_view(*r.track) : default_track;
    switch (r.kind) {
      case TraceRecord::Kind::Span:
        sink->span(r.a, r.b, r.core, track, r.name);
        break;
      case TraceRecord::Kind::Counter:
        sink->counter(r.a, r.core, r.name, r.value);
        break;
      case TraceRecord::Kind::Instant:
        sink->instant(r.a, r.core, track, r.name);
        break;
    }
  }
}

}  // namespace

HwRegulation hw_regulation(const Scenario& s, const MetricPlan& plan, const PmcSource& source,
                           const PolicyRegistry& policies, const Baselines* baselines) {
  HwRegulation out{regulation_setup(s, policies, baselines), ""};
  RegulationSetup& setup = out.setup;
  // The metric's events on this machine may differ from the scenario's (metric_plan.h); per-event
  // budgets follow the scenario's events, so they hold only where the plan kept them.
  if (plan.spec.events.size() != setup.metric.events.size()) setup.params.event_budget_mbps.clear();
  setup.metric = plan.spec;

  const TimeNs asked_ns = setup.sampling_period_ns;
  const TimeNs poll_ns = std::max(asked_ns, kHwFinestPollNs);
  const auto us_text = [](TimeNs ns) { return std::to_string(ns / kNsPerUs) + " us"; };
  const std::string period =
      us_text(poll_ns) +
      (poll_ns != asked_ns
           ? " (regulation.sampling_period_us " + us_text(asked_ns) +
                 " raised to the hw controller's finest, " + us_text(kHwFinestPollNs) + ")"
           : "");
  const auto external = [&](std::string why) {
    setup.sampling = Sampling::External;
    setup.sampling_period_ns = poll_ns;
    out.fallback = std::move(why);
    return out;
  };
  switch (setup.sampling) {
    case Sampling::Overflow: {
      std::string why;
      for (const auto& n : s.nodes.nrt)
        if (n.workload.is_command()) {
          why = "nRT node " + n.name +
                " runs an external command, counted with inherited perf events (the process and "
                "its children), which the kernel cannot sample as one count";
          break;
        }
      if (why.empty() && !s.nodes.nrt.empty()) {
        const std::vector<std::string> events(
            plan.group_events.begin(),
            plan.group_events.begin() + static_cast<std::ptrdiff_t>(plan.metric_events));
        if (auto u = source.overflow_unavailable(events)) why = *u;
      }
      if (why.empty()) return out;
      return external(
          "overflow sampling (" + setup.policy.name + ") cannot be armed on the hw backend here (" +
          why + "), so the controller reads the nRT cores' counters externally every " + period +
          " instead, and exceedance is seen up to one period late, not at once");
    }
    case Sampling::Mmio:
      return external("mmio sampling (" + setup.policy.name +
                      ") is not available on the hw backend: it cannot poll the cores' counters "
                      "through memory-mapped debug registers, so the controller reads them with "
                      "the PMC source every " +
                      period + " instead, and throttles through the nRT nodes' THR callback");
    case Sampling::Self:
    case Sampling::External:
      break;
  }
  return out;
}

PointRig::PointRig(const Scenario& s, const MetricPlan& plan, const PmcSource& source,
                   const RegulationSetup& regulation, const HwOptions& options, bool trace,
                   const ThrottleChoice& throttle)
    : s_(s),
      plan_(plan),
      source_(source),
      reg_(regulation),
      options_(options),
      trace_(trace),
      throttle_(throttle),
      origin_(now_ns()) {
  // Wiring: every publisher and subscriber exists before the first thread starts.
  make_topics();
  // The engine publishes the one activation of a point without RT node (publisher slot 0).
  if (s.nodes.rt.empty()) engine_pub_ = rt_topic_->add_publisher();
  wire_nodes();
  // The driver's activation accounting reads the nRT nodes through this meter, on the
  // controller thread, at both ends of every activation.
  meter_ = std::make_unique<NodeMeter>(nrts_, plan_);
  ControllerConfig cc;
  cc.core = s.nodes.controller_core;
  cc.sched = sched_of(s);
  cc.sampling = reg_.sampling;
  cc.sampling_period_ns = reg_.sampling_period_ns;
  cc.keepalive_ns = std::max<TimeNs>(kNsPerMs, s.hw.watchdog_ms * kNsPerMs / 4);
  cc.metric_events = plan.metric_events;
  cc.trace = trace;
  cc.fail_after_ns = options.controller_fail_after_ns;
  cc.rt_count = std::max<std::size_t>(1, s.nodes.rt.size());
  std::vector<Topic<ControlMsg>*> control_ptrs;
  for (std::size_t i = 0; i < controls_.size(); ++i) {
    control_ptrs.push_back(controls_[i].get());
    cc.entity_cores.push_back(s.nodes.nrt[i].core);
    cc.group_sizes.push_back(plan.group_events.size());
  }
  controller_ =
      std::make_unique<Controller>(cc, reg_.make_regulator(), *rt_topic_, *samples_, control_ptrs,
                                   meter_.get(), engine_waker_, errors_.handler(), origin_);
}

// The topics of the point's transport. DDS publisher slots follow the add_publisher() order of
// the wiring: the engine (no RT node) or the RT nodes run here, in scenario order, then the RT
// nodes signalled from outside (read, never written here); each nRT node's samples; the
// controller on each nRT node's control topic.
void PointRig::make_topics() {
  const std::size_t n_nrt = s_.nodes.nrt.size();
  if (s_.hw.transport == TransportKind::Inproc) {
    rt_topic_ = std::make_unique<InprocTopic<RtEventMsg>>();
    samples_ = std::make_unique<InprocTopic<SampleMsg>>();
    for (std::size_t i = 0; i < n_nrt; ++i)
      controls_.push_back(std::make_unique<InprocTopic<ControlMsg>>());
    return;
  }
  try {
    std::optional<dds::Security> security;
    if (const auto& f = s_.hw.dds_security) {
      // Relative to the scenario file.
      const auto path = [&](const std::string& p) {
        const std::filesystem::path fp = p;
        return (fp.is_absolute() ? fp : std::filesystem::path(s_.file).parent_path() / fp).string();
      };
      security = dds::Security{path(f->identity_ca), path(f->identity_certificate),
                               path(f->private_key), path(f->permissions_ca),
                               path(f->governance),  path(f->permissions)};
    }
    const std::string& ns = s_.hw.dds_namespace;
    // Announced to ROS 2 as the node <ns>/rosguard/run_<scenario name>.
    participant_ = std::make_unique<dds::Participant>(
        s_.hw.dds_domain_id, security ? &*security : nullptr,
        dds::RosNode{dds::rosguard_node_namespace(ns), dds::ros_node_name("run_" + s_.name)});
    std::vector<DdsSlot> rt_slots;
    if (s_.nodes.rt.empty()) rt_slots.push_back({"run", 0});
    for (int pass = 0; pass < 2; ++pass)
      for (std::size_t i = 0; i < s_.nodes.rt.size(); ++i)
        if ((s_.nodes.rt[i].signal == RtSignal::Topic) == (pass == 1))
          rt_slots.push_back({s_.nodes.rt[i].name, i});
    rt_topic_ = std::make_unique<DdsTopic<RtEventMsg>>(*participant_, ns, rt_slots);
    std::vector<DdsSlot> nrt_slots;
    for (std::size_t i = 0; i < n_nrt; ++i)
      nrt_slots.push_back({s_.nodes.nrt[i].name, i});
    samples_ = std::make_unique<DdsTopic<SampleMsg>>(*participant_, ns, nrt_slots);
    for (std::size_t i = 0; i < n_nrt; ++i)
      controls_.push_back(
          std::make_unique<DdsTopic<ControlMsg>>(*participant_, ns, std::vector{nrt_slots[i]}));
  } catch (const dds::DdsError& e) {
    throw RunError(std::string("DDS transport: ") + e.what());
  }
}

void PointRig::wire_nodes() {
  for (std::size_t i = 0; i < s_.nodes.nrt.size(); ++i) {
    const auto& n = s_.nodes.nrt[i];
    NrtConfig c;
    c.name = n.name;
    c.entity = i;
    c.core = n.core;
    c.sampling = reg_.sampling;
    c.sampling_period_ns = reg_.sampling_period_ns;
    c.watchdog_ns = s_.hw.watchdog_ms * kNsPerMs;
    c.mode = n.mode;
    c.sched = sched_of(s_);
    c.throttle = throttle_.kind;
    c.freezer_root = throttle_.freezer_root.value_or("");
    c.group_events = plan_.group_events;
    c.metric_events = plan_.metric_events;
    c.trace = trace_;
    nrts_.push_back(std::make_unique<NrtRunner>(c, n.workload, source_, *controls_[i], *samples_,
                                                engine_waker_, errors_.handler(), origin_));
  }
  for (std::size_t i = 0; i < s_.nodes.rt.size(); ++i) {
    if (s_.nodes.rt[i].signal == RtSignal::Topic) {
      external_rt_.push_back(i);
      rt_of_.push_back(nullptr);
      continue;
    }
    rts_.push_back(std::make_unique<RtRunner>(s_.nodes.rt[i], i, sched_of(s_), *rt_topic_,
                                              engine_waker_, errors_.handler(), origin_, trace_));
    rt_of_.push_back(rts_.back().get());
  }
}

PointRig::~PointRig() {
  teardown();
}

// nRT nodes to nominal first, then RT nodes, then the controller.
void PointRig::teardown() {
  if (torn_down_) return;
  torn_down_ = true;
  for (auto& n : nrts_)
    n->shutdown();
  for (auto& x : rts_)
    x->shutdown();
  if (controller_) controller_->shutdown();
  // Every thread is joined: no publish or take can run any more.
  for (auto& c : controls_) {
    dropped_commands_ += c->dropped();
    ignored_messages_ += c->ignored();
  }
  if (samples_) ignored_messages_ += samples_->ignored();
  if (rt_topic_) ignored_messages_ += rt_topic_->ignored();
  controls_.clear();
  samples_.reset();
  rt_topic_.reset();
  participant_.reset();
}

std::vector<SchedOutcome> PointRig::start() {
  for (auto& n : nrts_)
    n->start();
  // Groups exist only once the nRT nodes started (their NCT thread is the target).
  std::vector<CounterGroup*> groups;
  for (auto& n : nrts_)
    groups.push_back(&n->group());
  controller_->set_groups(groups);
  if (reg_.sampling == Sampling::Overflow) {
    // Overflow counters on each node's workload thread, for the metric's events.
    const std::vector<std::string> events(
        plan_.group_events.begin(),
        plan_.group_events.begin() + static_cast<std::ptrdiff_t>(plan_.metric_events));
    std::vector<std::unique_ptr<OverflowCounters>> counters;
    for (auto& n : nrts_) {
      PmcTarget target;
      target.kind = PmcTarget::Kind::Thread;
      target.pid = n->workload_tid();
      target.work = &n->work();
      counters.push_back(source_.open_overflow(events, target));
    }
    controller_->set_overflow(std::move(counters));
  }
  controller_->start();
  for (auto& x : rts_)
    x->start();
  std::vector<SchedOutcome> outcomes{controller_->outcome()};
  for (auto& n : nrts_)
    for (const auto& o : n->outcomes())
      outcomes.push_back(o);
  for (auto& x : rts_)
    outcomes.push_back(x->outcome());
  return outcomes;
}

// Everything that shows a point moving on: RT jobs started and ended (their own or, for another
// process's RT node, the signals the controller took) and nRT runs finished.
std::uint64_t PointRig::progress() const {
  std::uint64_t p = controller_->rt_events();
  for (const auto& x : rts_)
    p += static_cast<std::uint64_t>(x->published());
  for (const auto& n : nrts_)
    p += n->completed_runs() + (n->once_done() ? 1 : 0);
  return p;
}

bool PointRig::stalled() {
  const TimeNs now = now_ns();
  if (const auto p = progress(); p != last_progress_) {
    last_progress_ = p;
    last_progress_t_ = now;
    return false;
  }
  if (!stall_.empty()) return true;
  if (now - last_progress_t_ < s_.hw.progress_timeout_ms * kNsPerMs) return false;
  std::string states;
  for (const auto& n : nrts_)
    states +=
        (states.empty() ? "" : ", ") + n->config().name + " " + std::string(to_string(n->state()));
  stall_ = "no progress for " + std::to_string(s_.hw.progress_timeout_ms) +
           " ms (hw.progress_timeout_ms): no RT job started or ended, no nRT run finished and no "
           "signal was taken (nRT nodes: " +
           states + "); the point was stopped and every node returned to nominal";
  return true;
}

void PointRig::drive(RunContext& ctx) {
  last_progress_ = progress();
  last_progress_t_ = now_ns();
  const auto stopping = [&] { return ctx.stop_requested() || errors_.failed() || stalled(); };
  const auto nrt_once_done = [&] {
    for (auto& n : nrts_)
      if (n->config().mode == NrtMode::Once && !n->once_done()) return false;
    return true;
  };
  bool ok = true;
  if (s_.nodes.rt.empty()) {
    // No RT node: regulation covers the whole run. The activation starts (ON, baselines) before
    // the nRT nodes begin, so their runs lie entirely inside the regulation window.
    rt_topic_->publish(engine_pub_, {0, true, now_ns()});
    ok = wait_for(
        engine_waker_, [&] { return controller_->windows_opened() > 0; }, stopping);
  }
  if (ok)
    for (auto& n : nrts_)
      n->begin();
  const bool any_loop = std::any_of(
      nrts_.begin(), nrts_.end(), [](const auto& n) { return n->config().mode == NrtMode::Loop; });
  if (ok && !s_.nodes.rt.empty() && any_loop)
    ok = !wait_for(
             engine_waker_, [] { return false; }, stopping, options_.warmup_ns) &&
         !stopping();
  if (ok && s_.nodes.rt.empty()) {
    ok = wait_for(engine_waker_, nrt_once_done, stopping);
    if (ok) rt_topic_->publish(engine_pub_, {0, false, now_ns()});
  } else if (ok) {
    for (auto& x : rts_)
      x->go();
    const auto rts_done = [&] {
      for (auto& x : rts_)
        if (!x->done()) return false;
      return nrt_once_done();
    };
    if (external_rt_.empty()) {
      ok = wait_for(engine_waker_, rts_done, stopping);
    } else {
      // Another process runs these jobs; it may never come.
      const TimeNs limit = s_.hw.signal_timeout_ms * kNsPerMs;
      ok = wait_for(
          engine_waker_, [&] { return rts_done() && external_done(); }, stopping, limit);
      if (!ok && !stopping()) {
        std::string who;
        for (std::size_t i : external_rt_)
          if (controller_->rt_finished(i) < s_.nodes.rt[i].iterations)
            who += (who.empty() ? "" : ", ") + s_.nodes.rt[i].name + " (" +
                   std::to_string(controller_->rt_finished(i)) + " of " +
                   std::to_string(s_.nodes.rt[i].iterations) + " jobs)";
        signal_timeout_ = "RT node(s) signalled by topic did not finish their jobs within " +
                          std::to_string(s_.hw.signal_timeout_ms) +
                          " ms (hw.dds.signal_timeout_ms): " + who +
                          "; is the RT program running, on the same DDS domain and namespace?";
      }
    }
  }
  if (ok) wait_for_signals(ctx);
  if (controller_->failed_on_purpose()) {
    // The controller went silent: the nodes must come back on their own (watchdog).
    wait_for(
        engine_waker_,
        [&] {
          return std::all_of(nrts_.begin(), nrts_.end(),
                             [](const auto& n) { return n->state() == NodeState::Off; });
        },
        stopping, 2 * s_.hw.watchdog_ms * kNsPerMs + kWatchdogGraceNs);
  }
}

bool PointRig::external_done() const {
  for (std::size_t i : external_rt_)
    if (controller_->rt_finished(i) < s_.nodes.rt[i].iterations) return false;
  return true;
}

// Every enable / disable signal processed: the last OFF sent, the last activation accounted.
bool PointRig::wait_for_signals(RunContext& ctx) {
  int sent = s_.nodes.rt.empty() ? 2 : 0;
  for (auto& x : rts_)
    sent += x->published();
  for (std::size_t i : external_rt_)  // their ends are processed already (external_done())
    sent += 2 * s_.nodes.rt[i].iterations;
  return wait_for(
      engine_waker_,
      [&] { return controller_->rt_events() >= sent || controller_->failed_on_purpose(); },
      [&] { return ctx.stop_requested() || errors_.failed() || stalled(); },
      s_.hw.watchdog_ms * kNsPerMs + kSignalsGraceNs);
}

void PointRig::check_errors() const {
  if (errors_.failed()) throw RunError(errors_.message());
  if (!signal_timeout_.empty()) throw RunError(signal_timeout_);
  if (!stall_.empty()) throw RunError(stall_);
  if (dropped_commands_) throw RunError("a control topic dropped a command");
}

PointOutcome PointRig::outcome(RunContext& ctx) const {
  PointOutcome out;
  out.sampling = RanSampling{reg_.sampling, reg_.sampling_period_ns};
  for (std::size_t i = 0; i < s_.nodes.rt.size(); ++i) {
    const RtNodeSpec& spec = s_.nodes.rt[i];
    std::vector<double> job_ns, response_ns;
    if (const RtRunner* x = rt_of_[i]) {
      for (double j : x->job_times_us())
        job_ns.push_back(j * 1e3);
      for (double r : x->response_times_us())
        response_ns.push_back(r * 1e3);
      emit_trace(ctx.trace(), x->trace(), "rt");
    } else {
      // Jobs of another process: from its enable to its disable signal (publish stamps).
      TimeNs start = -1;
      for (const SignalRecord& r : controller_->signals()) {
        if (r.rt != i) continue;
        if (r.started) {
          start = r.t_sent;
        } else if (start >= 0) {
          job_ns.push_back(static_cast<double>(r.t_sent - start));
          start = -1;
        }
      }
      response_ns = job_ns;
    }
    std::optional<double> period_ns;
    if (const auto p = spec.period_ns()) period_ns = static_cast<double>(*p);
    out.rt.push_back(rt_outcome(spec.name, job_ns, response_ns, period_ns));
  }
  signal_samples(out);
  const ActivationTotals& totals = controller_->driver().totals();
  for (std::size_t i = 0; i < nrts_.size(); ++i) {
    const NrtRunner& n = *nrts_[i];
    NrtMeasure m;
    m.name = n.config().name;
    m.once = n.config().mode == NrtMode::Once;
    if (m.once) {
      if (n.once_done()) m.once_ns = n.once_time_us() * 1e3;
      m.runs = n.once_fraction();
    } else {
      // Work in runs, summed over the regulation windows. A built-in kernel does the same work
      // per unit (lines), so its isolation time is proportional to the work: uniform progress
      // gives exactly the isolation time of the units done. A command's progress cannot be
      // seen: it counts the processes that exited in the windows (whole runs).
      m.work_to = totals.active[i].work;
      m.progress = IsolationProgress::uniform(1.0);
      m.window_ns = totals.active_ns;
    }
    m.traffic = {totals.active[i].bytes, 0.0, 0.0};  // cycles not counted: bytes / active time
    m.traffic_ns = totals.active_ns;
    out.nrt.push_back(nrt_outcome(m, n.driver()));
    for (double v : n.activation_delays_us())
      out.samples.push_back({"activation_delay", v});
    for (double v : n.pmc_callbacks_us())
      out.samples.push_back({"pmc_callback", v});
    for (double v : n.pmc_reads_us())
      out.samples.push_back({"pmc_read", v});
    for (double v : n.sampling_overheads_us())
      out.samples.push_back({"sampling_overhead", v});
    for (const TraceLog* t : n.traces())
      emit_trace(ctx.trace(), *t, "nrt");
    if (n.watchdog_fired())
      ctx.fact("watchdog_fired", n.config().name + ": " + std::to_string(n.watchdog_fired()));
  }
  // External sampling: the controller's read of an nRT group is the sampling callback.
  for (double v : controller_->external_reads_us()) {
    out.samples.push_back({"pmc_callback", v});
    out.samples.push_back({"pmc_read", v});
  }
  report_external_lag(ctx);
  if (ignored_messages_)
    ctx.fallback("ignored_messages",
                 std::to_string(ignored_messages_) +
                     " message(s) on this run's DDS topics were ignored: written by another "
                     "process on the domain (only the run's own writers are read) or not "
                     "decodable (an unknown command code)");
  emit_trace(ctx.trace(), controller_->trace(), "controller");
  return out;
}

// signal_latency: an enable / disable signal from its publish to the controller taking it.
// signal_to_thr: an enable signal from its publish to the first THR entered on any nRT node
// before that RT job's disable signal was taken (jobs that were never throttled give none).
void PointRig::signal_samples(PointOutcome& out) const {
  const auto& sig = controller_->signals();
  std::vector<TimeNs> thr;
  for (const auto& n : nrts_)
    thr.insert(thr.end(), n->thr_entries().begin(), n->thr_entries().end());
  std::sort(thr.begin(), thr.end());
  for (std::size_t k = 0; k < sig.size(); ++k) {
    out.samples.push_back({"signal_latency", ns_to_us(sig[k].t_received - sig[k].t_sent)});
    if (!sig[k].started) continue;
    TimeNs until = std::numeric_limits<TimeNs>::max();
    for (std::size_t j = k + 1; j < sig.size(); ++j)
      if (sig[j].rt == sig[k].rt && !sig[j].started) {
        until = sig[j].t_received;
        break;
      }
    const auto it = std::lower_bound(thr.begin(), thr.end(), sig[k].t_sent);
    if (it != thr.end() && *it <= until)
      out.samples.push_back({"signal_to_thr", ns_to_us(*it - sig[k].t_sent)});
  }
}

// A round of reads longer than the sampling period leaves regulation late or inert.
void PointRig::report_external_lag(RunContext& ctx) const {
  const auto& reads = controller_->external_reads_us();
  const std::size_t n_nrt = nrts_.size();
  if (reg_.sampling == Sampling::Overflow) return;  // no periodic reads to be late
  const std::int64_t period_us = reg_.sampling_period_ns / kNsPerUs;
  const double round_budget_us =
      static_cast<double>(period_us) / static_cast<double>(std::max<std::size_t>(n_nrt, 1));
  const auto slow =
      std::count_if(reads.begin(), reads.end(), [&](double v) { return v >= round_budget_us; });
  if (slow > 0)
    ctx.fallback("external_sampling_lag",
                 std::to_string(slow) + " of " + std::to_string(reads.size()) +
                     " counter reads took longer than one sampling period allows (" +
                     std::to_string(period_us) + " us for " + std::to_string(n_nrt) +
                     " nRT core(s)): samples arrive late and regulation may never act; use a "
                     "longer sampling period");
}

}  // namespace rosguard::hw

// The hw backend: validate -> plan the metric -> wire nodes and topics -> run -> measure.
//
// Measurement notes (also in hw/README.md):
// - nRT bandwidth is Eq. 1 over the regulation window (first RT start -> last RT finish) with
//   cycles = window x frequency, i.e. bytes / window time: the counted core's cycles include the
//   time it spent throttled.
// - instrumented source: bytes are the lines the built-in kernel touched x line_bytes.
// - software source: no bandwidth events; bytes are estimated as task_clock x reference_mbps
//   (a time-based budget: the nRT node may run threshold% of the CPU time while the RT runs).
#include "hw/backend.h"

#include <sys/eventfd.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <limits>
#include <mutex>
#include <optional>
#include <set>

#include "core/error.h"
#include "engine/outcome.h"
#include "hw/common/clock.h"
#include "hw/common/sys.h"
#include "hw/nodes/controller.h"
#include "hw/nodes/nrt_node.h"
#include "hw/nodes/rt_node.h"
#include "policy/policy.h"
#include "policy/rules.h"
#include "results/results.h"

namespace rosguard::hw {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string cpu_list(const std::vector<int>& cpus) {
  std::string s;
  for (int c : cpus)
    s += (s.empty() ? "" : ", ") + std::to_string(c);
  return s.empty() ? "none" : s;
}

SchedClass sched_of(const Scenario& s) {
  return s.hw.scheduler == SchedulerKind::Fifo ? SchedClass::Fifo : SchedClass::Other;
}

// Waits on `waker` until pred() holds. SIGINT / SIGTERM interrupt the futex wait (the runner's
// handlers do not restart system calls, and node threads block those signals, so they reach
// this thread); the 100 ms deadline is only a safety net. Returns false when stopped or failed.
template <class Pred, class Stop>
bool wait_for(Waker& waker, Pred pred, Stop stop, TimeNs timeout_ns = -1) {
  const TimeNs give_up = timeout_ns < 0 ? -1 : now_ns() + timeout_ns;
  while (true) {
    const auto epoch = waker.epoch();
    if (pred()) return true;
    if (stop()) return false;
    const TimeNs now = now_ns();
    if (give_up >= 0 && now >= give_up) return false;
    TimeNs deadline = now + 100 * kNsPerMs;
    if (give_up >= 0) deadline = std::min(deadline, give_up);
    waker.wait(epoch, deadline);
  }
}

// Collects errors from node threads; the first one fails the point.
class ErrorBox {
 public:
  explicit ErrorBox(Waker& waker) : waker_(waker) {}
  RtThread::ErrorHandler handler() {
    return [this](const std::string& thread, std::exception_ptr e) {
      std::string what = "unknown error";
      try {
        std::rethrow_exception(e);
      } catch (const std::exception& x) {
        what = x.what();
      } catch (...) {
      }
      {
        std::lock_guard lock(mu_);
        if (message_.empty()) message_ = "thread " + thread + ": " + what;
      }
      failed_.store(true, std::memory_order_release);
      waker_.notify();
    };
  }
  bool failed() const { return failed_.load(std::memory_order_acquire); }
  std::string message() const {
    std::lock_guard lock(mu_);
    return message_;
  }

 private:
  Waker& waker_;
  mutable std::mutex mu_;
  std::string message_;
  std::atomic<bool> failed_{false};
};

// One stable message per kind of refusal (the runner keeps each distinct fallback once).
void report_sched(const std::vector<SchedOutcome>& outcomes, RunContext& ctx) {
  std::set<std::string> fifo, nice, pin;
  for (const auto& o : outcomes) {
    if (!o.fifo) fifo.insert(o.fifo_error);
    if (!o.nice_error.empty()) nice.insert(o.nice_error);
    if (!o.pinned) pin.insert(o.pin_error);
  }
  const auto join = [](const std::set<std::string>& v) {
    std::string s;
    for (const auto& x : v)
      s += (s.empty() ? "" : ", ") + x;
    return s;
  };
  if (!fifo.empty())
    ctx.fallback("sched_fifo",
                 "SCHED_FIFO refused (" + join(fifo) +
                     "): the node threads run under SCHED_OTHER with nice values in the same "
                     "priority order; the throttle and the callback priorities are approximate" +
                     (nice.empty() ? std::string()
                                   : "; raising priorities with nice was refused too (" +
                                         join(nice) + "), so they share the CPU at nice 0"));
  if (!pin.empty())
    ctx.fallback("affinity",
                 "a thread could not be pinned to its core (" + join(pin) + "): it runs unpinned");
}

void report_shared_core(const Scenario& s, RunContext& ctx) {
  const int c = s.nodes.controller_core;
  for (const auto& n : s.nodes.rt)
    if (n.core == c)
      ctx.fallback("shared_controller_core",
                   "the controller shares core " + std::to_string(c) + " with RT node '" + n.name +
                       "' (this host has " + std::to_string(usable_cpus().size()) +
                       " usable CPUs): its callbacks preempt the RT node's job");
  for (const auto& n : s.nodes.nrt)
    if (n.core == c)
      ctx.fallback("shared_controller_core",
                   "the controller shares core " + std::to_string(c) + " with nRT node '" + n.name +
                       "' (this host has " + std::to_string(usable_cpus().size()) +
                       " usable CPUs): it preempts the node's throttle when it runs");
}

// The safety net after every task: no thread that the task started may remain under a
// real-time policy (they have all been joined by now). Threads that were real-time before the
// task (e.g. rosguard itself started with chrt) are not the task's.
std::set<pid_t> realtime_tids() {
  std::set<pid_t> out;
  for (const auto& t : realtime_threads())
    out.insert(t.tid);
  return out;
}

std::size_t left_realtime(const std::set<pid_t>& before) {
  std::size_t n = 0;
  for (const auto& t : realtime_threads())
    n += before.count(t.tid) ? 0 : 1;
  return n;
}

void check_no_realtime_threads(const std::set<pid_t>& before) {
  std::string names;
  for (const auto& t : realtime_threads())
    if (!before.count(t.tid))
      names += (names.empty() ? "" : ", ") + t.name + " (" + std::to_string(t.tid) + ")";
  if (!names.empty())
    throw RunError("after the point, thread(s) still under a real-time policy: " + names);
}

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

// Idle spinners on the scenario's cores other than `busy` (RAII: stopped and joined on every
// path). They sit at the NCT priority and only execute pause instructions.
class IdleCores {
 public:
  IdleCores(const Scenario& s, int busy, SchedClass sched) {
    std::set<int> cores{s.nodes.controller_core};
    for (const auto& n : s.nodes.rt)
      cores.insert(n.core);
    for (const auto& n : s.nodes.nrt)
      cores.insert(n.core);
    cores.erase(busy);
    for (int c : cores)
      threads_.push_back(std::make_unique<RtThread>(
          ThreadSpec{"idle" + std::to_string(c), c, sched, prio::kNct}, [this] {
            while (!stop_.load(std::memory_order_relaxed))
              cpu_relax();
          }));
  }
  ~IdleCores() {
    stop_.store(true);
    for (auto& t : threads_)
      t->join();
  }
  IdleCores(const IdleCores&) = delete;
  IdleCores& operator=(const IdleCores&) = delete;
  std::vector<SchedOutcome> outcomes() const {
    std::vector<SchedOutcome> out;
    for (const auto& t : threads_)
      out.push_back(t->outcome());
    return out;
  }

 private:
  std::atomic<bool> stop_{false};
  std::vector<std::unique_ptr<RtThread>> threads_;
};

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

class HwBackend : public Backend {
 public:
  HwBackend(const PolicyRegistry& policies, HwOptions options)
      : policies_(policies), options_(options) {
    register_builtin(sources_);
  }

  std::string_view name() const override { return "hw"; }
  bool process_per_task() const override { return false; }

  void validate(const Scenario& s) const override {
    const auto cpus = usable_cpus();
    const auto check_core = [&](const std::string& path, int core) {
      if (std::find(cpus.begin(), cpus.end(), core) == cpus.end())
        throw InputError(s.file, path,
                         "core " + std::to_string(core) +
                             " is not available on this host (usable CPUs: " + cpu_list(cpus) +
                             "); the hw backend runs every node on a real core");
    };
    check_core("/nodes/controller/core", s.nodes.controller_core);
    for (std::size_t i = 0; i < s.nodes.rt.size(); ++i)
      check_core("/nodes/rt/" + std::to_string(i) + "/core", s.nodes.rt[i].core);
    for (std::size_t i = 0; i < s.nodes.nrt.size(); ++i)
      check_core("/nodes/nrt/" + std::to_string(i) + "/core", s.nodes.nrt[i].core);

    const auto check_workload = [&](const std::string& base, const WorkloadInfo& w) {
      if (w.is_command()) return;
      if (!w.doc.contains("hw"))
        throw InputError(s.file, base + "/workload",
                         "workload '" + w.name + "' has no \"hw\" implementation");
      const auto& hw = w.doc.at("hw");
      const std::string where = w.origin == "inline" ? s.file : w.origin;
      const std::string prefix = w.origin == "inline" ? base + "/workload/hw" : "/hw";
      if (hw.value("kernel", "") == "proxy" &&
          (!hw.contains("target_mbps") || hw.at("target_mbps").get<double>() <= 0.0))
        throw InputError(where, prefix + "/target_mbps",
                         "a proxy workload needs target_mbps > 0 (the bandwidth to reach)");
    };
    for (std::size_t i = 0; i < s.nodes.rt.size(); ++i)
      check_workload("/nodes/rt/" + std::to_string(i), s.nodes.rt[i].workload);
    for (std::size_t i = 0; i < s.nodes.nrt.size(); ++i)
      check_workload("/nodes/nrt/" + std::to_string(i), s.nodes.nrt[i].workload);

    check_policy(s, policies_);
    plan_metric(s, sources_);  // throws InputError for a source that cannot serve the scenario
  }

  IsolationResult isolation(const Scenario& s, const WorkloadInfo& w, int core, std::uint64_t,
                            RunContext& ctx) override {
    const MetricPlan plan = plan_metric(s, sources_);
    ctx.fact("pmc_source", plan.source);
    ctx.fact("isolation",
             "each workload alone on its core, unregulated, repetitions times (median); the "
             "scenario's other cores held by idle spinner threads meanwhile");
    const auto rt_before = realtime_tids();
    // The first second of busy work in a process runs slower on some hosts (frequency ramp-up,
    // host scheduling: bandwidth_read ran 14 % slower than later on the development VM), and
    // isolation runs come first: an unmeasured warm-up precedes the first of them.
    if (!warmed_up_) {
      const TimeNs until = now_ns() + kWarmUpNs;
      do {
        if (ctx.stop_requested()) throw Interrupted();
        run_alone(s, plan, w, core, ctx);
      } while (now_ns() < until);
      warmed_up_ = true;
      ctx.fact("warm_up",
               "one unmeasured second of the first isolation workload before any "
               "measurement");
    }
    std::vector<double> times, mbps, ipcs;
    for (int rep = 0; rep < s.repetitions; ++rep) {
      if (ctx.stop_requested()) throw Interrupted();
      const auto r = run_alone(s, plan, w, core, ctx);
      times.push_back(r.time_us);
      mbps.push_back(r.mbps);
      ipcs.push_back(r.ipc);
    }
    check_no_realtime_threads(rt_before);
    return {median(times), median(ipcs), median(mbps)};
  }

  PointOutcome run_point(const Scenario& s, const Baselines& baselines, int, std::uint64_t,
                         RunContext& ctx) override;

 private:
  IsolationResult run_alone(const Scenario& s, const MetricPlan& plan, const WorkloadInfo& w,
                            int core, RunContext& ctx);

  static constexpr TimeNs kWarmUpNs = kNsPerS;

  const PolicyRegistry& policies_;
  HwOptions options_;
  PmcSourceRegistry sources_;
  bool warmed_up_ = false;
};

IsolationResult HwBackend::run_alone(const Scenario& s, const MetricPlan& plan,
                                     const WorkloadInfo& w, int core, RunContext& ctx) {
  auto source = sources_.find(plan.source)->make();
  const bool counts = !plan.time_based && (!w.is_command() || source->counts_processes());
  const bool ipc = plan.source == "perf";
  Waker waker;
  ErrorBox errors(waker);
  std::atomic<bool> stop{false}, done{false};
  double time_us = 0.0, bytes = 0.0, cycles = 0.0, instructions = 0.0;
  Metric metric(plan.spec);
  std::unique_ptr<BuiltinWorkload> builtin;
  if (!w.is_command()) builtin = make_builtin_workload(w);
  Fd stop_fd(::eventfd(0, EFD_CLOEXEC));

  // The other cores of the scenario are held by idle spinners (no memory traffic) while the
  // workload runs alone, as they are held by the nodes' threads in a co-run: on a shared machine
  // other processes would otherwise run there and interfere with the isolation figure only.
  std::optional<ScopedSched> engine_sched(std::in_place,
                                          ThreadSpec{"", -1, sched_of(s), prio::kEngine});
  IdleCores idle(s, core, sched_of(s));
  report_sched(idle.outcomes(), ctx);

  const ThreadSpec spec{"isolation", core, sched_of(s), prio::kNct};
  RtThread thread(
      spec,
      [&] {
        struct Done {
          std::atomic<bool>& d;
          Waker& w;
          ~Done() {
            d.store(true, std::memory_order_release);
            w.notify();
          }
        } signal_done{done, waker};
        WorkCounters work;
        std::array<CounterValue, kMaxGroupEvents> v0{}, v1{}, i0{}, i1{};
        const std::size_t k = plan.metric_events;
        if (builtin) {
          PmcTarget target;
          target.work = &work;
          std::unique_ptr<CounterGroup> group, ipc_group;
          if (counts) group = source->open(plan.group_events, target);
          if (ipc) ipc_group = source->open({"cpu_cycles", "inst_retired"}, target);
          if (group) group->read(std::span(v0.data(), plan.group_events.size()));
          if (ipc_group) ipc_group->read(std::span(i0.data(), 2));
          const TimeNs t0 = now_ns();
          builtin->run(stop, work);
          const TimeNs t1 = now_ns();
          if (group) group->read(std::span(v1.data(), plan.group_events.size()));
          if (ipc_group) ipc_group->read(std::span(i1.data(), 2));
          time_us = ns_to_us(t1 - t0);
        } else {
          std::vector<std::string> argv;
          for (const auto& a : w.doc.at("command"))
            argv.push_back(a.get<std::string>());
          CommandProcess proc(argv, ThreadSpec{"isolation-cmd", core, sched_of(s), prio::kNct});
          PmcTarget target;
          target.kind = PmcTarget::Kind::Process;
          target.pid = proc.pid();
          target.enable_on_exec = true;
          std::unique_ptr<CounterGroup> group, ipc_group;
          if (counts) group = source->open(plan.group_events, target);
          if (ipc) ipc_group = source->open({"cpu_cycles", "inst_retired"}, target);
          const TimeNs t0 = now_ns();
          proc.start();
          if (!proc.wait(stop_fd.get())) return;
          const TimeNs t1 = now_ns();
          if (!(WIFEXITED(proc.status()) && WEXITSTATUS(proc.status()) == 0))
            throw RunError("isolation of '" + w.name + "': the command ended with " +
                           describe_status(proc.status()));
          if (group) group->read(std::span(v1.data(), plan.group_events.size()));
          if (ipc_group) ipc_group->read(std::span(i1.data(), 2));
          time_us = ns_to_us(t1 - t0);
        }
        if (counts) bytes = metric.delta_bytes(std::span(v0.data(), k), std::span(v1.data(), k));
        if (ipc) {
          cycles = scaled_delta(i0[0], i1[0], 64);
          instructions = scaled_delta(i0[1], i1[1], 64);
        }
      },
      errors.handler());
  report_sched({thread.outcome()}, ctx);
  const bool ok = wait_for(
      waker, [&] { return done.load(std::memory_order_acquire); },
      [&] { return ctx.stop_requested() || errors.failed(); });
  if (!ok) {
    stop.store(true);
    const std::uint64_t one = 1;
    ssize_t n = ::write(stop_fd.get(), &one, sizeof one);
    (void)n;
  }
  thread.join();
  if (errors.failed()) throw RunError("isolation of '" + w.name + "': " + errors.message());
  if (ctx.stop_requested()) throw Interrupted();
  IsolationResult r;
  r.time_us = time_us;
  r.mbps = counts && time_us > 0 ? bytes / kBytesPerMb / (time_us / 1e6) : kNaN;
  r.ipc = ipc && cycles > 0 ? instructions / cycles : kNaN;
  return r;
}

PointOutcome HwBackend::run_point(const Scenario& s, const Baselines& baselines, int, std::uint64_t,
                                  RunContext& ctx) {
  if (ctx.stop_requested()) throw Interrupted();
  const auto rt_before = realtime_tids();
  const MetricPlan plan = plan_metric(s, sources_);
  ctx.fact("pmc_source", plan.source);
  ctx.fact("pmc_source_choice", plan.why);
  ctx.fact("metric_basis", plan.basis);
  if (!plan.fallback.empty()) ctx.fallback("metric", plan.fallback);
  report_shared_core(s, ctx);
  auto source = sources_.find(plan.source)->make();
  const bool trace = ctx.trace() != nullptr;
  const SchedClass sched = sched_of(s);
  const RegulationSpec& r = s.regulation;
  const std::size_t n_nrt = s.nodes.nrt.size();
  const TimeNs origin = now_ns();

  Waker engine_waker;
  ErrorBox errors(engine_waker);
  Topic<RtEventMsg> rt_topic;
  Topic<SampleMsg> samples;
  std::vector<std::unique_ptr<Topic<ControlMsg>>> controls;
  for (std::size_t i = 0; i < n_nrt; ++i)
    controls.push_back(std::make_unique<Topic<ControlMsg>>());
  const std::size_t engine_pub = rt_topic.add_publisher();  // the activation when no RT node

  // Wiring: every publisher and subscriber exists before the first thread starts.
  std::vector<std::unique_ptr<NrtRunner>> nrts;
  for (std::size_t i = 0; i < n_nrt; ++i) {
    const auto& n = s.nodes.nrt[i];
    NrtConfig c;
    c.name = n.name;
    c.entity = i;
    c.core = n.core;
    c.sampling = r.sampling;
    c.sampling_period_ns = r.sampling_period_us * kNsPerUs;
    c.watchdog_ns = s.hw.watchdog_ms * kNsPerMs;
    c.mode = n.mode;
    c.sched = sched;
    c.group_events = plan.group_events;
    c.metric_events = plan.metric_events;
    c.trace = trace;
    nrts.push_back(std::make_unique<NrtRunner>(c, n.workload, *source, *controls[i], samples,
                                               engine_waker, errors.handler(), origin));
  }
  std::vector<std::unique_ptr<RtRunner>> rts;
  for (std::size_t i = 0; i < s.nodes.rt.size(); ++i)
    rts.push_back(std::make_unique<RtRunner>(s.nodes.rt[i], i, sched, rt_topic, engine_waker,
                                             errors.handler(), origin, trace));

  PolicyParams params;
  params.threshold_pct = r.threshold_pct;
  params.reference_mbps = r.reference_mbps;
  params.regulation_period_ns = r.regulation_period_us * kNsPerUs;
  if (!s.nodes.rt.empty())
    params.monolithic_window_ns = static_cast<TimeNs>(
        baselines.at(s, s.nodes.rt[0].workload, s.nodes.rt[0].core).time_us * 1e3);
  RegulatorConfig rc;
  rc.rt_count = std::max<std::size_t>(1, s.nodes.rt.size());
  rc.account_of_entity = accounts_for_scope(r.scope, n_nrt);
  rc.metric = plan.spec;
  auto regulator = std::make_unique<Regulator>(rc, policies_.make(r.policy, params));

  // The driver's activation accounting reads the nRT nodes through this meter, on the
  // controller thread, at both ends of every activation.
  NodeMeter meter(nrts, plan);
  ControllerConfig cc;
  cc.core = s.nodes.controller_core;
  cc.sched = sched;
  cc.sampling = r.sampling;
  cc.sampling_period_ns = r.sampling_period_us * kNsPerUs;
  cc.keepalive_ns = std::max<TimeNs>(kNsPerMs, s.hw.watchdog_ms * kNsPerMs / 4);
  cc.metric_events = plan.metric_events;
  cc.trace = trace;
  cc.fail_after_ns = options_.controller_fail_after_ns;
  std::vector<Topic<ControlMsg>*> control_ptrs;
  std::vector<CounterGroup*> groups;
  for (std::size_t i = 0; i < n_nrt; ++i) {
    control_ptrs.push_back(controls[i].get());
    cc.entity_cores.push_back(s.nodes.nrt[i].core);
    cc.group_sizes.push_back(plan.group_events.size());
  }
  // Groups exist only once the nRT nodes started (their NCT thread is the target): the
  // controller gets them through this vector, filled before its first activation.
  Controller controller(cc, std::move(regulator), rt_topic, samples, control_ptrs, &meter,
                        engine_waker, errors.handler(), origin);

  // The engine's thread above every node thread while they run (restored before the safety
  // check below; declared before the teardown so that unwinding tears down at this priority): it
  // must not wait for a time slice behind SCHED_FIFO threads on every core.
  std::optional<ScopedSched> engine_sched(std::in_place, ThreadSpec{"", -1, sched, prio::kEngine});
  // Every exit path from here: nRT nodes to nominal first, then RT nodes, then the controller.
  struct Teardown {
    std::vector<std::unique_ptr<NrtRunner>>& nrts;
    std::vector<std::unique_ptr<RtRunner>>& rts;
    Controller& controller;
    void operator()() {
      for (auto& n : nrts)
        n->shutdown();
      for (auto& x : rts)
        x->shutdown();
      controller.shutdown();
    }
    ~Teardown() { (*this)(); }
  } teardown{nrts, rts, controller};

  for (auto& n : nrts)
    n->start();
  for (auto& n : nrts)
    groups.push_back(&n->group());
  controller.set_groups(groups);
  controller.start();
  for (auto& x : rts)
    x->start();
  std::vector<SchedOutcome> outcomes{controller.outcome()};
  for (auto& n : nrts)
    for (const auto& o : n->outcomes())
      outcomes.push_back(o);
  for (auto& x : rts)
    outcomes.push_back(x->outcome());
  report_sched(outcomes, ctx);

  const auto stopping = [&] { return ctx.stop_requested() || errors.failed(); };
  const auto nrt_once_done = [&] {
    for (auto& n : nrts)
      if (n->config().mode == NrtMode::Once && !n->once_done()) return false;
    return true;
  };
  bool ok = true;
  if (rts.empty()) {
    // No RT node: regulation covers the whole run. The activation starts (ON, baselines) before
    // the nRT nodes begin, so their runs lie entirely inside the regulation window.
    rt_topic.publish(engine_pub, {0, true, now_ns()});
    ok = wait_for(
        engine_waker, [&] { return controller.windows_opened() > 0; }, stopping);
  }
  if (ok)
    for (auto& n : nrts)
      n->begin();
  const bool any_loop = std::any_of(
      nrts.begin(), nrts.end(), [](const auto& n) { return n->config().mode == NrtMode::Loop; });
  if (ok && !rts.empty() && any_loop)
    ok = !wait_for(
             engine_waker, [] { return false; }, stopping, options_.warmup_ns) &&
         !stopping();
  if (ok) {
    if (rts.empty()) {
      ok = wait_for(engine_waker, nrt_once_done, stopping);
      if (ok) rt_topic.publish(engine_pub, {0, false, now_ns()});
    } else {
      for (auto& x : rts)
        x->go();
      ok = wait_for(
          engine_waker,
          [&] {
            for (auto& x : rts)
              if (!x->done()) return false;
            return nrt_once_done();
          },
          stopping);
    }
  }
  if (ok) {
    // Every enable / disable signal processed: the last OFF sent, the last window measured.
    int sent = rts.empty() ? 2 : 0;
    for (auto& x : rts)
      sent += x->published();
    wait_for(
        engine_waker,
        [&] { return controller.rt_events() >= sent || controller.failed_on_purpose(); }, stopping,
        s.hw.watchdog_ms * kNsPerMs + 500 * kNsPerMs);
  }
  if (controller.failed_on_purpose()) {
    // The controller went silent: the nodes must come back on their own (watchdog).
    wait_for(
        engine_waker,
        [&] {
          return std::all_of(nrts.begin(), nrts.end(),
                             [](const auto& n) { return n->state() == NodeState::Off; });
        },
        stopping, 2 * s.hw.watchdog_ms * kNsPerMs + 500 * kNsPerMs);
  }
  teardown();
  engine_sched.reset();
  if (ctx.stop_requested()) {
    std::cerr << "hw: interrupted; " << nrts.size()
              << " nRT node(s) returned to nominal, every node thread joined, "
              << left_realtime(rt_before) << " thread(s) left under SCHED_FIFO\n";
    throw Interrupted();
  }
  check_no_realtime_threads(rt_before);
  if (errors.failed()) throw RunError(errors.message());
  for (auto& c : controls)
    if (c->dropped()) throw RunError("a control topic dropped a command");

  PointOutcome out;
  for (auto& x : rts) {
    std::vector<double> job_ns;
    for (double j : x->job_times_us())
      job_ns.push_back(j * 1e3);
    out.rt.push_back(rt_outcome(x->spec().name, job_ns));
    emit_trace(ctx.trace(), x->trace(), "rt");
  }
  const ActivationTotals& totals = controller.driver().totals();
  for (std::size_t i = 0; i < n_nrt; ++i) {
    NrtRunner& n = *nrts[i];
    NrtMeasure m;
    m.name = n.config().name;
    m.once = n.config().mode == NrtMode::Once;
    if (m.once) {
      if (n.once_done()) m.once_ns = n.once_time_us() * 1e3;
      m.runs = n.once_fraction();
    } else {
      m.runs = totals.active[i].work;
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
  for (double v : controller.external_reads_us()) {
    out.samples.push_back({"pmc_callback", v});
    out.samples.push_back({"pmc_read", v});
  }
  emit_trace(ctx.trace(), controller.trace(), "controller");
  return out;
}

}  // namespace

MetricPlan plan_metric(const Scenario& s, const PmcSourceRegistry& sources) {
  const auto& wanted = s.regulation.metric.events;
  bool all_builtin = true;
  std::size_t first_command = 0;
  for (std::size_t i = 0; i < s.nodes.nrt.size(); ++i)
    if (s.nodes.nrt[i].workload.is_command() && all_builtin) {
      all_builtin = false;
      first_command = i;
    }
  const auto make = [&](const std::string& name) { return sources.find(name)->make(); };
  const auto provides_all = [&](const PmcSource& src) {
    for (const auto& e : wanted)
      if (!src.provides(e.name)) return false;
    return true;
  };

  MetricPlan plan;
  switch (s.hw.pmc_source) {
    case PmcSourceKind::Perf: {
      auto src = make("perf");
      if (auto why = src->unavailable_reason())
        throw InputError(s.file, "/hw/pmc_source",
                         "pmc_source \"perf\" cannot count hardware events on this host: " + *why +
                             "; use \"auto\", \"instrumented\" or \"software\"");
      for (const auto& e : wanted)
        if (!src->provides(e.name))
          throw InputError(s.file, "/regulation/metric/events/" + e.name,
                           "the perf source has no event '" + e.name + "' on this host");
      plan.source = "perf";
      plan.why = "requested";
      break;
    }
    case PmcSourceKind::Instrumented: {
      if (!all_builtin)
        throw InputError(s.file, "/nodes/nrt/" + std::to_string(first_command) + "/workload",
                         "pmc_source \"instrumented\" counts only built-in workloads, and this "
                         "nRT node runs an external command; use \"auto\", \"software\" or "
                         "\"perf\"");
      auto src = make("instrumented");
      for (const auto& e : wanted)
        if (!src->provides(e.name))
          throw InputError(s.file, "/regulation/metric/events/" + e.name,
                           "the instrumented source counts l2d_cache_refill and l2d_cache_wb "
                           "only, not '" +
                               e.name + "'");
      plan.source = "instrumented";
      plan.why = "requested";
      break;
    }
    case PmcSourceKind::Software:
      plan.source = "software";
      plan.why = "requested";
      break;
    case PmcSourceKind::Auto: {
      auto perf = make("perf");
      const auto perf_why = perf->unavailable_reason();
      if (!perf_why && provides_all(*perf)) {
        plan.source = "perf";
        plan.why = "auto: the hardware PMU works";
      } else if (all_builtin && provides_all(*make("instrumented"))) {
        plan.source = "instrumented";
        plan.why = "auto: no usable hardware PMU (" +
                   (perf_why ? *perf_why : std::string("events missing")) +
                   "); every nRT workload is built in";
      } else {
        plan.source = "software";
        plan.why = "auto: no usable hardware PMU (" +
                   (perf_why ? *perf_why : std::string("events missing")) +
                   ") and an nRT workload is an external command";
      }
      break;
    }
  }

  plan.spec = s.regulation.metric;
  if (plan.source == "software") {
    if (auto why = make("software")->unavailable_reason())
      throw InputError(s.file, "/hw/pmc_source", "perf software events do not work here: " + *why);
    // Time-based budget: bytes = task_clock ns x reference bytes per ns. The nRT node may then
    // run threshold% of each regulation period while an RT node runs.
    plan.group_events = software_group_events();
    plan.metric_events = 1;
    const double bytes_per_ns = s.regulation.reference_mbps * kBytesPerMb / 1e9;
    plan.spec.events = {{"task_clock", bytes_per_ns / plan.spec.line_bytes}};
    plan.spec.counter_bits = 64;
    plan.time_based = true;
    plan.basis = "time-based budget: bytes = task_clock ns x reference_mbps (" +
                 std::to_string(s.regulation.reference_mbps) + " MB/s)";
    std::string names;
    for (const auto& e : wanted)
      names += (names.empty() ? "" : ", ") + e.name;
    plan.fallback = "the software source has no bandwidth events (" + names +
                    "): regulating with a time-based budget, bytes = task_clock x reference_mbps";
  } else {
    for (const auto& e : wanted)
      plan.group_events.push_back(e.name);
    plan.metric_events = plan.group_events.size();
    if (plan.source == "instrumented") {
      plan.spec.counter_bits = 64;
      plan.basis =
          "instrumented: lines touched by the built-in kernels (reads -> l2d_cache_refill, "
          "writes -> l2d_cache_refill + l2d_cache_wb) x line_bytes; Eq. 1 with cycles = elapsed "
          "time x frequency";
    } else {
      plan.spec.counter_bits = 64;  // perf_event_open accumulates into 64-bit values
      plan.basis = "perf hardware events, Eq. 1";
    }
  }
  return plan;
}

std::unique_ptr<Backend> make_hw_backend(const PolicyRegistry& policies, HwOptions options) {
  return std::make_unique<HwBackend>(policies, options);
}

}  // namespace rosguard::hw

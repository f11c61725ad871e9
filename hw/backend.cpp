// The hw backend: validate -> plan the metric (hw/metric_plan.h) -> wire the point's rig
// (hw/point_rig.h) -> run it through the wait protocol (hw/wait.h) -> measure; the real-time
// safety net (hw/safety_net.h) after every task; isolation runs in hw/isolation.h.
//
// Measurement notes (also in hw/README.md):
// - nRT bandwidth is Eq. 1 over the regulation-active time (the controller's activations) with
//   cycles = time x frequency, i.e. bytes / active time: the counted core's cycles include the
//   time it spent throttled.
// - instrumented source: bytes are the lines the built-in kernel touched x line_bytes.
// - software source: no bandwidth events; bytes are estimated as task_clock x reference_mbps
//   (a time-based budget: the nRT node may run threshold% of the CPU time while the RT runs).
#include "hw/backend.h"

#include <algorithm>
#include <iostream>
#include <map>
#include <optional>
#include <tuple>

#include "core/error.h"
#include "hw/common/clock.h"
#include "hw/common/sys.h"
#include "hw/isolation.h"
#include "hw/point_rig.h"
#include "hw/safety_net.h"
#include "hw/topic/dds/dds.h"
#include "policy/rules.h"
#include "results/results.h"

namespace rosguard::hw {
namespace {

std::string cpu_list(const std::vector<int>& cpus) {
  std::string s;
  for (int c : cpus)
    s += (s.empty() ? "" : ", ") + std::to_string(c);
  return s.empty() ? "none" : s;
}

// The transport in the manifest; for DDS, where a ROS 2 user finds the traffic.
void report_transport(const Scenario& s, RunContext& ctx) {
  ctx.fact("transport", std::string(to_string(s.hw.transport)));
  if (s.hw.transport != TransportKind::Dds) return;
  std::uint32_t domain = 0;
  try {
    domain = s.hw.dds_domain_id ? *s.hw.dds_domain_id : dds::default_domain_id();
  } catch (const dds::DdsError& e) {
    throw RunError(e.what());
  }
  const std::string ns = s.hw.dds_namespace;
  ctx.fact("dds", "Cyclone DDS " DDS_VERSION ", domain " + std::to_string(domain) +
                      (s.hw.dds_domain_id ? "" : " (ROS_DOMAIN_ID or 0)") + ", topics " + ns +
                      "/rosguard/<node>/{active,pmc,command} (DDS rt" + ns +
                      "/rosguard/...), ROS 2 default QoS (reliable, keep last 10, volatile)");
}

class HwBackend : public Backend {
 public:
  HwBackend(const PolicyRegistry& policies, HwOptions options)
      : policies_(policies), options_(options) {
    register_builtin(sources_);
  }

  std::string_view name() const override { return "hw"; }
  bool process_per_task() const override { return false; }
  int baseline_repetitions(const Scenario& s) const override { return s.hw.baseline_repetitions; }

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

    if (const auto why = throttle_unavailable(s.hw.throttle, commands_only(s)))
      throw InputError(s.file, "/hw/throttle", *why);

    check_policy(s, policies_);
    plan_metric(s, sources_);  // throws InputError for a source that cannot serve the scenario
  }

  IsolationResult isolation(const Scenario& s, const WorkloadInfo& w, int core, std::uint64_t,
                            RunContext& ctx) override {
    const MetricPlan plan = plan_metric(s, sources_);
    ctx.fact("pmc_source", plan.source);
    ctx.fact("isolation",
             "each workload alone on its core, unregulated, measured hw.baseline_repetitions "
             "times interleaved with the repetition rounds (median); the scenario's other cores "
             "held by idle spinner threads meanwhile");
    const auto rt_before = realtime_tids();
    try {
      warm_up(s, plan, w, core, ctx);
      if (ctx.stop_requested()) throw Interrupted();
      const IsolationResult r = measure_alone(s, plan, sources_, w, core, ctx);
      check_no_realtime_threads(rt_before);
      return r;
    } catch (const Interrupted&) {
      // Baselines are measured between the points, so a stop often lands in one: say what was
      // left behind as run_point does.
      std::cerr << "hw: interrupted during an isolation run; every thread joined, "
                << left_realtime(rt_before) << " thread(s) left under SCHED_FIFO\n";
      throw;
    }
  }

  PointOutcome run_point(const Scenario& s, const Baselines& baselines, int, std::uint64_t,
                         RunContext& ctx) override;

 private:
  static bool commands_only(const Scenario& s) {
    return std::all_of(s.nodes.nrt.begin(), s.nodes.nrt.end(),
                       [](const NrtNodeSpec& n) { return n.workload.is_command(); });
  }

  // The throttle mechanism of the run's points, picked (and measured) once per distinct need.
  const ThrottleChoice& throttle_for(const Scenario& s, RunContext& ctx) {
    static const ThrottleChoice kNone{};
    if (s.nodes.nrt.empty()) return kNone;
    ThrottleNeeds needs;
    needs.mode = s.hw.throttle;
    needs.scenario_sched = sched_of(s);
    needs.commands_only = commands_only(s);
    needs.core = s.nodes.nrt.front().core;
    const auto key =
        std::make_tuple(needs.mode, needs.scenario_sched, needs.commands_only, needs.core);
    auto it = throttles_.find(key);
    if (it == throttles_.end()) it = throttles_.emplace(key, choose_throttle(needs)).first;
    const ThrottleChoice& c = it->second;
    ctx.fact("throttle", std::string(to_string(c.kind)));
    ctx.fact("throttle_choice", c.why);
    std::string holds;
    for (const auto& m : c.measured)
      holds += (holds.empty() ? "" : "; ") + describe_hold(m) +
               (m.detail.empty() ? "" : " [" + m.detail + "]");
    ctx.fact("throttle_hold",
             "nRT progress while throttled / nominal, measured at run start on "
             "CPU " +
                 std::to_string(needs.core) + " (6 windows of 20 ms): " + holds);
    if (!c.fallback.empty()) ctx.fallback("throttle", c.fallback);
    return c;
  }

  // The first second of busy work in a process runs slower on some hosts (frequency ramp-up,
  // host scheduling: bandwidth_read ran 14 % slower than later on the development VM), and
  // isolation runs come first: an unmeasured warm-up precedes the first of them.
  void warm_up(const Scenario& s, const MetricPlan& plan, const WorkloadInfo& w, int core,
               RunContext& ctx) {
    if (warmed_up_) return;
    const TimeNs until = now_ns() + kWarmUpNs;
    do {
      if (ctx.stop_requested()) throw Interrupted();
      measure_alone(s, plan, sources_, w, core, ctx);
    } while (now_ns() < until);
    warmed_up_ = true;
    ctx.fact("warm_up",
             "one unmeasured second of the first isolation workload before any measurement");
  }

  static constexpr TimeNs kWarmUpNs = kNsPerS;

  const PolicyRegistry& policies_;
  HwOptions options_;
  PmcSourceRegistry sources_;
  bool warmed_up_ = false;
  std::map<std::tuple<ThrottleMode, SchedClass, bool, int>, ThrottleChoice> throttles_;
};

PointOutcome HwBackend::run_point(const Scenario& s, const Baselines& baselines, int, std::uint64_t,
                                  RunContext& ctx) {
  if (ctx.stop_requested()) throw Interrupted();
  const auto rt_before = realtime_tids();
  const MetricPlan plan = plan_metric(s, sources_);
  ctx.fact("pmc_source", plan.source);
  ctx.fact("pmc_source_choice", plan.why);
  ctx.fact("metric_basis", plan.basis);
  if (!plan.fallback.empty()) ctx.fallback("metric", plan.fallback);
  if (const HwSampling hs = hw_sampling(s); !hs.fallback.empty())
    ctx.fallback("sampling", hs.fallback);
  if (plan.spec.events.size() != s.regulation.metric.events.size() &&
      !s.regulation.event_budget_mbps.empty())
    ctx.fallback("event_budget",
                 "regulation.event_budget_mbps is not applied: the PMC source " + plan.source +
                     " counts other events than the scenario's metric (" + plan.basis + ")");
  report_shared_core(s, ctx);
  report_transport(s, ctx);
  const auto source = sources_.find(plan.source)->make();
  const ThrottleChoice& throttle = throttle_for(s, ctx);
  // The engine's thread above every node thread while they run (restored before the safety
  // check below; declared before the rig so that unwinding tears the rig down at this priority):
  // it must not wait for a time slice behind SCHED_FIFO threads on every core.
  std::optional<ScopedSched> engine_sched(std::in_place,
                                          ThreadSpec{"", -1, sched_of(s), prio::kEngine});
  PointRig rig(s, plan, *source, make_point_regulator(s, plan, baselines, policies_), options_,
               ctx.trace() != nullptr, throttle);
  report_sched(rig.start(), ctx);
  rig.drive(ctx);
  rig.teardown();
  engine_sched.reset();
  if (ctx.stop_requested()) {
    std::cerr << "hw: interrupted; " << rig.nrt_count()
              << " nRT node(s) returned to nominal, every node thread joined, "
              << left_realtime(rt_before) << " thread(s) left under SCHED_FIFO\n";
    throw Interrupted();
  }
  check_no_realtime_threads(rt_before);
  rig.check_errors();
  return rig.outcome(ctx);
}

}  // namespace

std::unique_ptr<Backend> make_hw_backend(const PolicyRegistry& policies, HwOptions options) {
  return std::make_unique<HwBackend>(policies, options);
}

}  // namespace rosguard::hw

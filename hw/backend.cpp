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
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <tuple>

#include "core/error.h"
#include "hw/common/clock.h"
#include "hw/common/sys.h"
#include "hw/cpu_speed.h"
#include "hw/housekeeping.h"
#include "hw/isolation.h"
#include "hw/point_rig.h"
#include "hw/safety_net.h"
#include "hw/topic/dds/dds.h"
#include "regulator/setup.h"
#include "results/results.h"

namespace rosguard::hw {
namespace {

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

std::string fixed1(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", v);
  return buf;
}

// The cgroup v2 mount point, or empty.
std::string cgroup2_mount() {
  std::ifstream in("/proc/self/mountinfo");
  for (std::string line; std::getline(in, line);) {
    const auto dash = line.find(" - ");
    if (dash == std::string::npos || line.compare(dash + 3, 8, "cgroup2 ") != 0) continue;
    std::istringstream head(line.substr(0, dash));
    std::string id, parent, devno, root, mount;
    head >> id >> parent >> devno >> root >> mount;
    return mount;
  }
  return {};
}

// What this host offers to keep other work off the measured cores, for the manifest: SCHED_FIFO
// (node threads above every SCHED_OTHER task), and whether a cgroup v2 cpuset could fence the
// cores off (not used by this version: hw/README.md, Threads).
std::string host_isolation_offers() {
  std::string out;
  if (const auto refused = fifo_refused())
    out = "SCHED_FIFO refused (" + *refused +
          "): node threads run under SCHED_OTHER (nice values) or the idle / freezer throttles, "
          "and other tasks of the host share the measured cores with them";
  else
    out =
        "SCHED_FIFO allowed: node threads preempt every SCHED_OTHER task of the host on their "
        "cores (within the kernel's real-time budget, sched_rt_runtime_us)";
  const std::string mount = cgroup2_mount();
  std::string controllers;
  if (!mount.empty()) {
    std::ifstream in(mount + "/cgroup.controllers");
    std::getline(in, controllers);
  }
  if (mount.empty())
    out += "; no cgroup v2 hierarchy mounted (no cpuset partition possible)";
  else if (controllers.find("cpuset") == std::string::npos)
    out += "; cgroup v2 at " + mount + " has no cpuset controller (cgroup.controllers: \"" +
           controllers + "\")";
  else
    out += "; cgroup v2 at " + mount +
           " offers cpuset: an exclusive partition of the measured cores is possible but not "
           "made by this version";
  return out;
}

class HwBackend : public Backend {
 public:
  HwBackend(const PolicyRegistry& policies, HwOptions options)
      : policies_(policies), options_(options) {
    register_builtin(sources_);
  }

  std::string_view name() const override { return "hw"; }
  bool process_per_task() const override { return false; }
  bool judges_precision() const override { return true; }
  RunSetup prepare_run(const std::vector<const Scenario*>& points) override;
  int baseline_repetitions(const Scenario& s) const override { return s.hw.baseline_repetitions; }

  void validate(const Scenario& s) const override {
    const auto cpus = usable_cpus();
    const auto check_core = [&](const std::string& path, int core) {
      if (std::find(cpus.begin(), cpus.end(), core) == cpus.end())
        throw InputError(s.file, path,
                         "core " + std::to_string(core) +
                             " is not available on this host (usable CPUs: " + cpu_list_text(cpus) +
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

    regulation_setup(s, policies_);  // throws InputError for a rule of the policy broken
    plan_metric(s, sources_);  // throws InputError for a source that cannot serve the scenario
  }

  IsolationResult isolation(const Scenario& s, const WorkloadInfo& w, int core, std::uint64_t,
                            RunContext& ctx) override {
    const MetricPlan plan = plan_metric(s, sources_);
    ctx.fact("pmc_source", plan.source);
    const char* when =
        s.hw.adjacent_baselines
            ? "for each point, right before each of its repetitions (hw.adjacent_baselines: a "
              "repetition's slowdowns divide by these)"
        : s.hw.precision_pct ? "once before each round of its points (hw.precision_pct; median)"
                             : "hw.baseline_repetitions times interleaved with the repetition "
                               "rounds (median)";
    ctx.fact("isolation", std::string("each workload alone on its core, unregulated, measured ") +
                              when +
                              "; the scenario's other cores held by idle spinner threads "
                              "meanwhile; a built-in kernel's run that was on its core less "
                              "than " +
                              std::to_string(std::lround(kMinOnCore * 100)) +
                              " % of its time (RT throttling, a higher priority) is taken again, "
                              "up to " +
                              std::to_string(kOnCoreAttempts) + " attempts");
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

  // Which threads run where while a point runs, once per transport (the manifest's
  // thread_placement_<transport>); threads on a measured core that is not their node's are a
  // fallback (a thread rosguard did not place).
  void audit_threads(const Scenario& s, RunContext& ctx);

  const PolicyRegistry& policies_;
  HwOptions options_;
  PmcSourceRegistry sources_;
  bool warmed_up_ = false;
  std::optional<HousekeepingPin> housekeeping_;  // rosguard's own threads, for the whole run
  std::vector<int> housekeeping_cpus_;
  std::set<std::string> audited_;  // transports whose placement is in the manifest
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
  if (plan.spec.events.size() != s.regulation.metric.events.size() &&
      !s.regulation.event_budget_mbps.empty())
    ctx.fallback("event_budget",
                 "regulation.event_budget_mbps is not applied: the PMC source " + plan.source +
                     " counts other events than the scenario's metric (" + plan.basis + ")");
  report_shared_core(s, ctx);
  report_transport(s, ctx);
  const auto source = sources_.find(plan.source)->make();
  const HwRegulation regulation = hw_regulation(s, plan, *source, policies_, &baselines);
  if (!regulation.fallback.empty()) ctx.fallback("sampling", regulation.fallback);
  if (regulation.setup.sampling == Sampling::Overflow && !s.nodes.nrt.empty()) {
    std::string events;
    for (std::size_t i = 0; i < plan.metric_events; ++i)
      events += (events.empty() ? "" : ", ") + plan.group_events[i];
    ctx.fact("overflow_sampling",
             "overflow counters (" + events + ", " + plan.source +
                 " source) on each nRT node's workload thread, armed with the budget left, "
                 "signal the controller thread, which reads the node and throttles it at once");
  }
  const ThrottleChoice& throttle = throttle_for(s, ctx);
  // The engine's thread above every node thread while they run (restored before the safety
  // check below; declared before the rig so that unwinding tears the rig down at this priority):
  // it must not wait for a time slice behind SCHED_FIFO threads on every core.
  std::optional<ScopedSched> engine_sched(std::in_place,
                                          ThreadSpec{"", -1, sched_of(s), prio::kEngine});
  PointRig rig(s, plan, *source, regulation.setup, options_, ctx.trace() != nullptr, throttle);
  report_sched(rig.start(), ctx);
  if (const dds::ReceiveBinding* b = rig.dds_binding()) {
    if (b->bound)
      ctx.fact("dds_receive_binding", b->text);
    else
      ctx.fallback("dds_binding", b->text);
  }
  audit_threads(s, ctx);
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

RunSetup HwBackend::prepare_run(const std::vector<const Scenario*>& points) {
  RunSetup setup;
  if (points.empty()) return setup;
  std::set<int> measured, controller;
  for (const Scenario* s : points) {
    controller.insert(s->nodes.controller_core);
    for (const auto& n : s->nodes.rt)
      measured.insert(n.core);
    for (const auto& n : s->nodes.nrt)
      measured.insert(n.core);
  }
  // 1. rosguard's own threads and processes off the measured cores, for the whole run.
  const HousekeepingPlan plan = plan_housekeeping(usable_cpus(), measured, controller);
  housekeeping_.emplace(plan.cpus);
  if (!housekeeping_->error().empty()) {
    setup.fallbacks.emplace_back("housekeeping", housekeeping_->error() + "; they run unpinned");
  } else {
    housekeeping_cpus_ = plan.cpus;
    setup.facts["housekeeping"] =
        plan.detail +
        ". There: the runner (engine thread, row writes, progress), the DDS participant's "
        "threads (they inherit the engine thread's mask), the supervisors of external commands "
        "once their command started; no task host (one point at a time in this process)";
    std::cerr << "hw: rosguard's own threads on " << plan.detail << "\n";
    if (plan.kind == HousekeepingPlan::Kind::SharedController)
      setup.warnings.push_back("rosguard's own threads share a measured core: " + plan.detail);
  }
  setup.facts["host_isolation"] = host_isolation_offers();

  // 2. The measured CPUs timed alone, to see a slow one before its figures are taken for
  // contention.
  const std::vector<int> cpus(measured.begin(), measured.end());
  const CpuSpeedReport speed = time_cpus(cpus, sched_of(*points.front()));
  nlohmann::json per_cpu = nlohmann::json::object();
  std::string line;
  for (const auto& c : speed.cpus) {
    per_cpu[std::to_string(c.cpu)] = {{"mbps", c.mbps},
                                      {"cv", std::isfinite(c.cv) ? nlohmann::json(c.cv) : nullptr},
                                      {"windows_mbps", c.windows_mbps},
                                      {"pinned", c.pinned}};
    line += (line.empty() ? "" : ", ") + std::string("CPU ") + std::to_string(c.cpu) + " " +
            fixed1(c.mbps / 1024.0) + " GiB/s" + (c.pinned ? "" : " (unpinned)");
  }
  const auto slow = slow_cpus(speed.cpus, kSlowCpuMargin);
  double fastest = 0.0;
  int fastest_cpu = -1;
  for (const auto& c : speed.cpus)
    if (std::isfinite(c.mbps) && c.mbps > fastest) {
      fastest = c.mbps;
      fastest_cpu = c.cpu;
    }
  nlohmann::json slow_list = nlohmann::json::array();
  for (const auto& c : slow)
    slow_list.push_back(c.cpu);
  const std::string method = "bandwidth_read " + std::to_string(speed.options.working_set_kb) +
                             " KB alone on each, median of " +
                             std::to_string(speed.options.windows) + " windows of " +
                             fixed1(speed.options.window_ms) + " ms interleaved over the CPUs";
  setup.manifest["cpu_speed"] = {{"method", method},
                                 {"margin_pct", 100.0 * kSlowCpuMargin},
                                 {"passes_per_window", speed.passes},
                                 {"cpus", per_cpu},
                                 {"slower_than_fastest", slow_list}};
  if (!speed.cpus.empty())
    std::cerr << "hw: measured CPUs alone (" << method << "): " << line << "\n";
  for (const auto& c : slow)
    setup.warnings.push_back(
        "CPU " + std::to_string(c.cpu) + " ran " + method.substr(0, method.find(" alone")) + " " +
        fixed1(100.0 * (1.0 - c.mbps / fastest)) + " % slower than CPU " +
        std::to_string(fastest_cpu) + " (" + fixed1(c.mbps / 1024.0) + " against " +
        fixed1(fastest / 1024.0) + " GiB/s, margin " + fixed1(100.0 * kSlowCpuMargin) +
        " %): this host's CPUs are not equal (a VM's vCPUs), so a node on it is slower alone "
        "and its slowdowns compare only with its own baselines; the manifest's cpu_speed has "
        "every figure");
  return setup;
}

void HwBackend::audit_threads(const Scenario& s, RunContext& ctx) {
  // Node threads by name (hw/nodes: the RT node's name, "<nRT name>-<callback>", "controller";
  // the kernel keeps 15 characters).
  std::vector<std::string> node_names{"controller"};
  for (const auto& n : s.nodes.rt)
    node_names.push_back(n.name.substr(0, 15));
  for (const auto& n : s.nodes.nrt)
    node_names.push_back(n.name.substr(0, 15));
  const auto is_node = [&](const std::string& thread) {
    return std::any_of(node_names.begin(), node_names.end(),
                       [&](const std::string& n) { return thread.rfind(n, 0) == 0; });
  };
  const std::set<int> home(housekeeping_cpus_.begin(), housekeeping_cpus_.end());
  std::map<std::string, int> node_threads;  // CPUs -> how many
  std::vector<std::string> at_home, stray;
  for (const auto& t : thread_placements()) {
    if (is_node(t.name)) {
      ++node_threads[cpu_ranges(t.cpus)];
    } else if (!home.empty() && std::all_of(t.cpus.begin(), t.cpus.end(),
                                            [&](int c) { return home.count(c) > 0; })) {
      at_home.push_back(t.name);
    } else {
      stray.push_back(t.name + " (CPU " + cpu_ranges(t.cpus) + ")");
    }
  }
  const auto join = [](const std::vector<std::string>& v) {
    std::string out;
    for (const auto& x : v)
      out += (out.empty() ? "" : ", ") + x;
    return out;
  };
  const std::string transport(to_string(s.hw.transport));
  if (audited_.insert(transport).second) {
    std::string nodes;
    for (const auto& [cpus, n] : node_threads)
      nodes += (nodes.empty() ? "" : ", ") + std::to_string(n) + " on CPU " + cpus;
    ctx.fact("thread_placement_" + transport,
             "while a point runs: " + std::to_string(at_home.size()) +
                 " thread(s) of rosguard on CPU " + cpu_ranges(housekeeping_cpus_) + " (" +
                 join(at_home) + "); node threads: " + (nodes.empty() ? "none" : nodes) +
                 (stray.empty() ? "" : "; elsewhere: " + join(stray)));
  }
  if (!stray.empty() && !home.empty())
    ctx.fallback("housekeeping", "thread(s) of rosguard neither on CPU " +
                                     cpu_ranges(housekeeping_cpus_) +
                                     " nor a node's while a point ran: " + join(stray));
}

}  // namespace

std::unique_ptr<Backend> make_hw_backend(const PolicyRegistry& policies, HwOptions options) {
  return std::make_unique<HwBackend>(policies, options);
}

}  // namespace rosguard::hw

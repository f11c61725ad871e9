#include "scenario/scenario.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "core/error.h"
#include "policy/rules.h"

namespace rosguard {
namespace {

Sampling parse_sampling(const std::string& s) {
  if (s == "external") return Sampling::External;
  if (s == "overflow") return Sampling::Overflow;
  if (s == "mmio") return Sampling::Mmio;
  return Sampling::Self;
}

Scope parse_scope(const std::string& s) {
  if (s == "node") return Scope::Node;
  if (s == "group") return Scope::Group;
  return Scope::Core;
}

PmcSourceKind parse_pmc_source(const std::string& s) {
  if (s == "perf") return PmcSourceKind::Perf;
  if (s == "software") return PmcSourceKind::Software;
  if (s == "instrumented") return PmcSourceKind::Instrumented;
  return PmcSourceKind::Auto;
}

// %g: 2, 0.5, 35840.
std::string number_text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

std::string core_range(const PlatformInfo& p) {
  return p.cores() == 1 ? "core 0" : "cores 0-" + std::to_string(p.cores() - 1);
}

}  // namespace

std::string_view to_string(NrtMode m) {
  return m == NrtMode::Loop ? "loop" : "once";
}

std::string_view to_string(PmcSourceKind k) {
  switch (k) {
    case PmcSourceKind::Auto:
      return "auto";
    case PmcSourceKind::Perf:
      return "perf";
    case PmcSourceKind::Software:
      return "software";
    case PmcSourceKind::Instrumented:
      return "instrumented";
  }
  return "?";
}

std::string_view to_string(SchedulerKind k) {
  return k == SchedulerKind::Fifo ? "fifo" : "other";
}

std::string_view to_string(ThrottleMode m) {
  switch (m) {
    case ThrottleMode::Auto:
      return "auto";
    case ThrottleMode::Fifo:
      return "fifo";
    case ThrottleMode::Idle:
      return "idle";
    case ThrottleMode::Freezer:
      return "freezer";
  }
  return "auto";
}

ThrottleMode parse_throttle_mode(const std::string& s) {
  if (s == "fifo") return ThrottleMode::Fifo;
  if (s == "idle") return ThrottleMode::Idle;
  if (s == "freezer") return ThrottleMode::Freezer;
  return ThrottleMode::Auto;
}

std::string_view to_string(TransportKind k) {
  return k == TransportKind::Dds ? "dds" : "inproc";
}

std::string_view to_string(RtSignal s) {
  return s == RtSignal::Topic ? "topic" : "self";
}

PlatformInfo build_platform(const nlohmann::json& doc, const std::string& file) {
  PlatformInfo p;
  p.name = doc.at("name").get<std::string>();
  p.origin = file;
  const auto& cpu = doc.at("cpu");
  p.clusters = cpu.at("clusters").get<int>();
  p.cores_per_cluster = cpu.at("cores_per_cluster").get<int>();
  p.freq_mhz = cpu.at("freq_mhz").get<double>();
  p.line_bytes = doc.at("caches").at("line_bytes").get<std::uint32_t>();
  p.reference_mbps = doc.at("reference").at("mbps").get<double>();
  p.pmu_events = doc.at("pmu").at("events").get<std::vector<std::string>>();
  p.counter_bits = doc.at("pmu").at("counter_bits").get<unsigned>();
  p.doc = doc;
  return p;
}

WorkloadInfo size_working_set(const WorkloadInfo& w, const PlatformInfo& platform,
                              const std::string& file, const std::string& pointer) {
  if (w.is_command() || !w.doc.contains("hw") || !w.doc.at("hw").contains("working_set")) return w;
  const auto& spec = w.doc.at("hw").at("working_set");
  const std::string cache = spec.at("cache").get<std::string>();
  const double times = spec.at("times").get<double>();
  const auto& caches = platform.doc.at("caches");
  const char* key = cache == "l2" ? "l2_kb" : "l3_kb_per_cluster";
  const double cache_kb = caches.value(key, 0.0);
  if (!(cache_kb > 0.0))
    throw InputError(file, pointer + "/cache",
                     "platform " + platform.name + " reports no " + (cache == "l2" ? "L2" : "L3") +
                         " size (caches." + key +
                         "), so a working set relative to it cannot be sized; give "
                         "working_set_kb instead");
  constexpr double kMinKb = 4.0, kMaxKb = 16777216.0;  // working_set_kb's bounds
  const double kb = std::round(times * cache_kb);
  if (kb < kMinKb || kb > kMaxKb)
    throw InputError(file, pointer + "/times",
                     number_text(times) + " x the " + (cache == "l2" ? "L2" : "L3") +
                         " of platform " + platform.name + " (" + number_text(cache_kb) +
                         " KB) is " + number_text(kb) + " KB, outside 4 .. 16777216 KB");
  nlohmann::json doc = w.doc.get();
  doc["hw"]["working_set_kb"] = static_cast<std::int64_t>(kb);
  return WorkloadInfo{w.name, w.origin, std::move(doc)};
}

namespace {

// Assigns nodes to cores: each core exists on the platform and runs at most one application
// node, and node names are unique. Every problem is recorded at its node (problems()), so that
// one report names them all: a core taken twice does not hide a core that does not exist.
class NodePlacer {
 public:
  explicit NodePlacer(const PlatformInfo& plat) : plat_(plat) {}

  // False (and a problem recorded) when `core` is not on the platform; `at` is the JSON pointer
  // of the core value.
  bool check_core_exists(const std::string& at, int core) {
    if (core < plat_.cores()) return true;
    problems_.emplace_back(at, "core " + std::to_string(core) + " does not exist on platform " +
                                   plat_.name + " (" + core_range(plat_) + ")");
    return false;
  }

  // `base` is the node's JSON pointer ("/nodes/rt/0").
  void place(const std::string& base, const std::string& name, int core) {
    if (check_core_exists(base + "/core", core)) {
      if (auto it = core_owner_.find(core); it != core_owner_.end())
        problems_.emplace_back(
            base + "/core", "core " + std::to_string(core) + " already runs node '" + it->second +
                                "' (one RT or nRT node per core: a throttled node's idle " +
                                "loop would starve the other)");
      else
        core_owner_[core] = name;
    }
    if (auto it = name_owner_.find(name); it != name_owner_.end())
      problems_.emplace_back(base + "/name",
                             "node name '" + name + "' is already used at " + it->second);
    else
      name_owner_[name] = base;
  }

  const std::vector<std::pair<std::string, std::string>>& problems() const { return problems_; }

 private:
  const PlatformInfo& plat_;
  std::map<int, std::string> core_owner_;
  std::map<std::string, std::string> name_owner_;
  std::vector<std::pair<std::string, std::string>> problems_;  // (JSON pointer, message)
};

void build_rt_nodes(const nlohmann::json& rt, std::vector<WorkloadInfo>& workloads,
                    NodePlacer& placer, const std::string& file, NodesSpec& nodes) {
  if (workloads.size() != rt.size()) throw InputError(file, "/nodes/rt", "unresolved workloads");
  for (std::size_t i = 0; i < rt.size(); ++i) {
    RtNodeSpec n;
    n.name = rt[i].at("name").get<std::string>();
    n.core = rt[i].at("core").get<int>();
    n.workload = std::move(workloads[i]);
    n.iterations = rt[i].at("iterations").get<int>();
    if (rt[i].contains("period_us")) n.period_us = rt[i].at("period_us").get<std::int64_t>();
    n.signal = rt[i].value("signal", "self") == "topic" ? RtSignal::Topic : RtSignal::Self;
    placer.place("/nodes/rt/" + std::to_string(i), n.name, n.core);
    nodes.rt.push_back(std::move(n));
  }
}

void build_nrt_nodes(const nlohmann::json& nrt, bool has_rt, std::vector<WorkloadInfo>& workloads,
                     NodePlacer& placer, const std::string& file, NodesSpec& nodes) {
  if (workloads.size() != nrt.size()) throw InputError(file, "/nodes/nrt", "unresolved workloads");
  for (std::size_t i = 0; i < nrt.size(); ++i) {
    const std::string base = "/nodes/nrt/" + std::to_string(i);
    NrtNodeSpec n;
    n.name = nrt[i].at("name").get<std::string>();
    n.core = nrt[i].at("core").get<int>();
    n.workload = std::move(workloads[i]);
    // Without an RT node nothing would end a loop: nRT nodes then run once.
    const std::string mode = nrt[i].value("mode", has_rt ? "loop" : "once");
    if (mode == "loop" && !has_rt)
      throw InputError(file, base + "/mode",
                       "'loop' restarts the workload until the RT nodes finish, and there is "
                       "no RT node; use \"once\"");
    n.mode = mode == "loop" ? NrtMode::Loop : NrtMode::Once;
    placer.place(base, n.name, n.core);
    nodes.nrt.push_back(std::move(n));
  }
}

// The workload's hw kernel has a model in the platform's "kernels": sim runs it from that model
// (sim/workload/profile.h: profile_for), no "sim" section needed.
bool kernel_modelled(const WorkloadInfo& w, const PlatformInfo& plat) {
  if (w.is_command() || !w.doc.contains("hw") || !plat.doc.contains("kernels")) return false;
  const std::string kernel = w.doc.at("hw").value("kernel", "");
  const auto& kernels = plat.doc.at("kernels");
  return kernels.contains(kernel) && kernels.at(kernel).is_object();
}

// The node at `base` runs workload `w`: the scenario's backend must be able to run it.
void check_workload_runs_on(const std::string& backend, const std::string& base,
                            const WorkloadInfo& w, const PlatformInfo& plat,
                            const std::string& file) {
  const std::string at = base + "/workload";
  if (w.is_command() && backend == "sim" && !w.doc.contains("sim"))
    throw InputError(file, at,
                     "an external command without a \"sim\" profile runs only on the hw backend "
                     "(run with --backend hw, or give it a profile: rosguard profile)");
  if (!w.is_command() && backend == "sim" && !w.doc.contains("sim") && !kernel_modelled(w, plat))
    throw InputError(file, at,
                     "workload '" + w.name + "' (" + w.origin +
                         ") has no \"sim\" profile, so the sim backend cannot run it");
  if (!w.is_command() && backend == "hw" && !w.doc.contains("hw"))
    throw InputError(file, at,
                     "workload '" + w.name + "' (" + w.origin +
                         ") has no \"hw\" implementation, so the hw backend cannot run it");
}

// Nodes: cores exist, names unique, one application node per core, workloads the backend runs.
NodesSpec build_nodes(const nlohmann::json& nodes, ResolvedRefs& refs, const std::string& backend,
                      const std::string& file) {
  const PlatformInfo& plat = refs.platform;
  NodesSpec out;
  NodePlacer placer(plat);
  out.controller_core = nodes.at("controller").at("core").get<int>();
  placer.check_core_exists("/nodes/controller/core", out.controller_core);

  const auto& rt = nodes.at("rt");
  build_rt_nodes(rt, refs.rt_workloads, placer, file, out);
  build_nrt_nodes(nodes.at("nrt"), !rt.empty(), refs.nrt_workloads, placer, file, out);
  if (!placer.problems().empty()) throw InputError(file, placer.problems());
  if (out.rt.empty() && out.nrt.empty())
    throw InputError(file, "/nodes", "no RT and no nRT node: nothing to run");

  for (std::size_t i = 0; i < out.rt.size(); ++i)
    check_workload_runs_on(backend, "/nodes/rt/" + std::to_string(i), out.rt[i].workload, plat,
                           file);
  for (std::size_t i = 0; i < out.nrt.size(); ++i)
    check_workload_runs_on(backend, "/nodes/nrt/" + std::to_string(i), out.nrt[i].workload, plat,
                           file);
  return out;
}

// The metric's events, each one the platform's PMU provides.
std::vector<MetricEvent> build_metric_events(const nlohmann::json& events, const PlatformInfo& plat,
                                             const std::string& file) {
  std::vector<MetricEvent> out;
  for (const auto& [event, weight] : events.items()) {
    if (std::find(plat.pmu_events.begin(), plat.pmu_events.end(), event) == plat.pmu_events.end()) {
      std::string known;
      for (const auto& e : plat.pmu_events)
        known += (known.empty() ? "" : ", ") + e;
      throw InputError(file, "/regulation/metric/events/" + event,
                       "event '" + event + "' is not provided by platform " + plat.name +
                           " (it has: " + known + ")");
    }
    out.push_back({event, weight.get<double>()});
  }
  return out;
}

HwSettings build_hw_settings(const nlohmann::json& hw, int repetitions, const std::string& file) {
  HwSettings out;
  out.pmc_source = parse_pmc_source(hw.at("pmc_source").get<std::string>());
  out.scheduler =
      hw.at("scheduler").get<std::string>() == "fifo" ? SchedulerKind::Fifo : SchedulerKind::Other;
  out.throttle = parse_throttle_mode(hw.value("throttle", std::string("auto")));
  out.watchdog_ms = hw.at("watchdog_ms").get<std::int64_t>();
  // Three measurements give a median that one outlier cannot move.
  out.baseline_repetitions = std::max(repetitions, 3);
  if (hw.contains("baseline_repetitions")) {
    out.baseline_repetitions = hw.at("baseline_repetitions").get<int>();
    if (out.baseline_repetitions < repetitions)
      throw InputError(file, "/hw/baseline_repetitions",
                       "must be at least repetitions (" + std::to_string(repetitions) +
                           "): every repetition round needs a baseline measured before it");
  }
  out.adjacent_baselines = hw.value("adjacent_baselines", false);
  if (out.adjacent_baselines) {
    if (hw.contains("baseline_repetitions"))
      throw InputError(file, "/hw/baseline_repetitions",
                       "not with hw.adjacent_baselines: each repetition has its own baseline "
                       "measurement, taken right before its co-run");
    out.baseline_repetitions = repetitions;
  }
  if (hw.contains("precision_pct")) out.precision_pct = hw.at("precision_pct").get<double>();
  out.max_repetitions = hw.value("max_repetitions", 20);
  if (out.precision_pct && out.max_repetitions < repetitions)
    throw InputError(file, "/hw/max_repetitions",
                     "must be at least repetitions (" + std::to_string(repetitions) +
                         "): with hw.precision_pct, repetitions is the fewest rounds a point runs "
                         "and max_repetitions the most");
  out.progress_timeout_ms = hw.value("progress_timeout_ms", std::int64_t{60000});
  out.transport =
      hw.value("transport", "inproc") == "dds" ? TransportKind::Dds : TransportKind::Inproc;
  if (hw.contains("dds")) {
    const auto& dds = hw.at("dds");
    if (dds.contains("domain_id")) out.dds_domain_id = dds.at("domain_id").get<std::uint32_t>();
    out.dds_namespace = dds.value("namespace", "");
    out.signal_timeout_ms = dds.value("signal_timeout_ms", std::int64_t{60000});
    if (dds.contains("security")) {
      const auto& j = dds.at("security");
      out.dds_security = DdsSecurityFiles{
          j.at("identity_ca").get<std::string>(), j.at("identity_certificate").get<std::string>(),
          j.at("private_key").get<std::string>(), j.at("permissions_ca").get<std::string>(),
          j.at("governance").get<std::string>(),  j.at("permissions").get<std::string>()};
    }
  }
  return out;
}

}  // namespace

RegulationSpec build_regulation(const nlohmann::json& reg, const PlatformInfo& plat,
                                const NodesSpec& nodes, const std::string& file) {
  RegulationSpec r;
  r.policy = reg.at("policy").get<std::string>();
  r.sampling = parse_sampling(reg.at("sampling").get<std::string>());
  r.sampling_period_us = reg.at("sampling_period_us").get<std::int64_t>();
  r.regulation_period_us = reg.at("regulation_period_us").get<std::int64_t>();
  r.threshold_pct = reg.at("threshold_pct").get<double>();
  r.reference_from_platform = !reg.contains("reference_mbps");
  r.reference_mbps =
      r.reference_from_platform ? plat.reference_mbps : reg.at("reference_mbps").get<double>();
  r.scope = parse_scope(reg.at("scope").get<std::string>());
  const auto& metric = reg.at("metric");
  r.metric.line_bytes = metric.at("line_bytes").get<std::uint32_t>();
  r.metric.counter_bits = plat.counter_bits;
  r.metric.events = build_metric_events(metric.at("events"), plat, file);

  if (reg.contains("budget_mbps")) {
    const auto& b = reg.at("budget_mbps");
    if (b.is_number()) {
      r.budget_mbps = {b.get<double>()};
    } else {
      // One per nRT node, by name: every nRT node has one, and every name is an nRT node.
      if (r.scope == Scope::Group)
        throw InputError(file, "/regulation/budget_mbps",
                         "budgets per nRT node need scope core or node: scope group has one "
                         "budget for all nRT nodes (give one number)");
      for (const auto& [name, value] : b.items()) {
        const bool known = std::any_of(nodes.nrt.begin(), nodes.nrt.end(),
                                       [&](const NrtNodeSpec& n) { return n.name == name; });
        if (!known)
          throw InputError(file, "/regulation/budget_mbps/" + name,
                           "'" + name + "' is not an nRT node of this scenario");
      }
      for (std::size_t i = 0; i < nodes.nrt.size(); ++i) {
        if (!b.contains(nodes.nrt[i].name))
          throw InputError(file, "/regulation/budget_mbps",
                           "no budget for nRT node '" + nodes.nrt[i].name +
                               "': give every nRT node one, or one number for all");
        r.budget_mbps.push_back(b.at(nodes.nrt[i].name).get<double>());
      }
    }
  }
  if (reg.contains("event_budget_mbps")) {
    const auto& eb = reg.at("event_budget_mbps");
    for (const auto& [event, value] : eb.items()) {
      const bool known =
          std::any_of(r.metric.events.begin(), r.metric.events.end(),
                      [&, &event = event](const MetricEvent& e) { return e.name == event; });
      if (!known) {
        std::string names;
        for (const auto& e : r.metric.events)
          names += (names.empty() ? "" : ", ") + e.name;
        throw InputError(file, "/regulation/event_budget_mbps/" + event,
                         "'" + event + "' is not an event of the regulation metric (" + names +
                             "): a per-event budget counts one of the metric's events");
      }
    }
    for (const auto& e : r.metric.events)
      r.event_budget_mbps.push_back(eb.contains(e.name) ? eb.at(e.name).get<double>()
                                                        : std::numeric_limits<double>::infinity());
  }
  r.global_budget_mbps = reg.value("global_budget_mbps", 0.0);
  r.reclaim = reg.value("reclaim", false);
  const std::string sharing = reg.value("sharing", std::string("off"));
  r.sharing = sharing == "last" ? Sharing::Last : sharing == "all" ? Sharing::All : Sharing::Off;
  return r;
}

Scenario build_scenario(const nlohmann::json& doc, ResolvedRefs refs, const std::string& file) {
  Scenario s;
  s.file = file;
  s.document = doc;
  s.name = doc.at("name").get<std::string>();
  s.description = doc.value("description", "");
  s.backend = doc.at("backend").get<std::string>();
  s.seed = doc.at("seed").get<std::uint64_t>();
  s.repetitions = doc.at("repetitions").get<int>();
  s.nodes = build_nodes(doc.at("nodes"), refs, s.backend, file);
  s.platform = std::move(refs.platform);
  s.regulation = build_regulation(doc.at("regulation"), s.platform, s.nodes, file);

  // Rules of the built-in policies; a policy registered elsewhere is checked by the backends
  // (regulation_setup with the run's registry).
  if (const PolicyInfo* p = find_builtin_policy(s.regulation.policy))
    check_policy_rules(s.regulation, {s.nodes.rt.size(), s.nodes.nrt.size()}, p->traits, file);

  s.sim.quantum_us = doc.at("sim").at("quantum_us").get<double>();
  s.hw = build_hw_settings(doc.at("hw"), s.repetitions, file);
  // DDS topics carry node names as ROS 2 name tokens.
  if (s.hw.transport == TransportKind::Dds) {
    const auto check_token = [&](const std::string& at, const std::string& name) {
      const bool ok = !name.empty() && !(name[0] >= '0' && name[0] <= '9') &&
                      std::all_of(name.begin(), name.end(), [](char c) {
                        return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
                               (c >= '0' && c <= '9') || c == '_';
                      });
      if (!ok)
        throw InputError(
            file, at,
            "'" + name +
                "' cannot be a ROS 2 topic name token (hw.transport dds: "
                "/rosguard/<node>/...): letters, digits and '_', not starting with a digit");
    };
    for (std::size_t i = 0; i < s.nodes.rt.size(); ++i)
      check_token("/nodes/rt/" + std::to_string(i) + "/name", s.nodes.rt[i].name);
    for (std::size_t i = 0; i < s.nodes.nrt.size(); ++i)
      check_token("/nodes/nrt/" + std::to_string(i) + "/name", s.nodes.nrt[i].name);
  }
  // An RT node signalled from another process exists only on hw, over DDS.
  for (std::size_t i = 0; i < s.nodes.rt.size(); ++i) {
    if (s.nodes.rt[i].signal != RtSignal::Topic) continue;
    const std::string at = "/nodes/rt/" + std::to_string(i) + "/signal";
    if (s.backend != "hw")
      throw InputError(file, at,
                       "signal 'topic' (jobs run by another process) needs the hw backend");
    if (s.hw.transport != TransportKind::Dds)
      throw InputError(file, at, "signal 'topic' needs hw.transport 'dds'");
    if (s.nodes.rt[i].period_us)
      throw InputError(file, "/nodes/rt/" + std::to_string(i) + "/period_us",
                       "the process that publishes the signal sets the period, not the scenario");
  }
  return s;
}

namespace {

// One run of a sim workload at its base IPC, in seconds; nullopt without a sim profile. A
// built-in kernel with a model in the platform's "kernels" runs from that model in sim
// (sim/workload/profile.h: kernel_profile): its lines at the faster of its two base times.
std::optional<double> min_run_seconds(const WorkloadInfo& w, const PlatformInfo& platform) {
  const double freq_mhz = platform.freq_mhz;
  if (!w.is_command() && w.doc.contains("hw") && platform.doc.contains("kernels")) {
    const auto& hw = w.doc.at("hw");
    const auto& kernels = platform.doc.at("kernels");
    const std::string kernel = hw.value("kernel", "");
    if (kernels.contains(kernel) && kernels.at(kernel).is_object()) {
      const auto& k = kernels.at(kernel);
      const double lines = hw.value("working_set_kb", 2048.0) * 1024.0 / 64.0;
      const double ns =
          std::min(k.at("ns_per_line_l2").get<double>(), k.at("ns_per_line_l3").get<double>());
      return lines * hw.value("passes", 1.0) * ns * 1e-9;
    }
  }
  if (!w.doc.contains("sim") || freq_mhz <= 0.0) return std::nullopt;
  const auto& sim = w.doc.at("sim");
  const double instructions = sim.at("instructions").get<double>();
  double cycles = 0.0;
  for (const auto& phase : sim.at("phases"))
    cycles +=
        instructions * phase.at("fraction").get<double>() / phase.at("base_ipc").get<double>();
  return cycles / (freq_mhz * 1e6);
}

}  // namespace

std::optional<double> min_simulated_seconds(const Scenario& s) {
  double longest = 0.0;
  for (const auto& rt : s.nodes.rt) {
    const auto job = min_run_seconds(rt.workload, s.platform);
    if (!job) return std::nullopt;
    const double slot =
        rt.period_us ? std::max(*job, static_cast<double>(*rt.period_us) * 1e-6) : *job;
    longest = std::max(longest, slot * rt.iterations);
  }
  if (s.nodes.rt.empty())
    for (const auto& nrt : s.nodes.nrt) {
      const auto run = min_run_seconds(nrt.workload, s.platform);
      if (!run) return std::nullopt;
      longest = std::max(longest, *run);
    }
  return longest;
}

}  // namespace rosguard

#include "tune/guard_config.h"

#include <cctype>
#include <cmath>
#include <map>
#include <set>

namespace rosguard {

using json = nlohmann::json;

namespace {

// The guard schema's floor for both periods (its controller reads a core with a system call).
constexpr std::int64_t kGuardMinPeriodUs = 100;

const std::map<std::string, std::string>& sampling_refusals() {
  static const std::map<std::string, std::string> why = {
      {"self",
       "self sampling needs the regulated program to read and publish its own counters; the "
       "guard regulates unmodified processes and reads their cores itself (external sampling)"},
      {"overflow",
       "the guard does not arm per-core PMU overflow interrupts: it reads every core from its "
       "controller (external sampling)"},
      {"mmio",
       "MemPol's polling of the cores' debug registers is not reachable from a Linux process: "
       "the guard reads the cores through perf or their CPU time (external sampling)"},
  };
  return why;
}

std::string valid_name(const std::string& name) {
  std::string out;
  for (char c : name)
    out += (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-') ? c : '-';
  while (!out.empty() && !std::isalnum(static_cast<unsigned char>(out.front())))
    out.erase(out.begin());
  if (out.empty()) out = "tuned";
  return out.substr(0, 128);
}

}  // namespace

std::optional<std::string> guard_refusal(const std::vector<std::string>& paths,
                                         const json& values) {
  static const std::set<std::string> kept = {"regulation.policy",
                                             "regulation.sampling",
                                             "regulation.sampling_period_us",
                                             "regulation.regulation_period_us",
                                             "regulation.scope",
                                             "regulation.reclaim",
                                             "regulation.sharing",
                                             "regulation.global_budget_mbps",
                                             "regulation.reference_mbps"};
  for (std::size_t i = 0; i < paths.size(); ++i) {
    const std::string& p = paths[i];
    const json& v = values.at(i);
    if (v.is_null()) continue;
    if (!kept.count(p))
      return p +
             " has no key in a guard configuration (it budgets each core, or all of them, "
             "by threshold_pct of reference_mbps)";
    if (p == "regulation.sampling" && v != "external") {
      const auto it = sampling_refusals().find(v.get<std::string>());
      return it != sampling_refusals().end() ? it->second
                                             : v.get<std::string>() + " sampling is not deployed";
    }
    if ((p == "regulation.sampling_period_us" || p == "regulation.regulation_period_us") &&
        v.get<std::int64_t>() < kGuardMinPeriodUs)
      return p.substr(11) + " " + std::to_string(v.get<std::int64_t>()) +
             " us: the guard's controller reads a core with a system call (perf or a thread's "
             "task clock, about 10 us each); its periods start at " +
             std::to_string(kGuardMinPeriodUs) + " us";
    if (p == "regulation.scope" && v == "node")
      return "scope node: the guard budgets each core (scope core) or all of them (group)";
  }
  return std::nullopt;
}

std::optional<std::string> guard_placement_refusal(const NodesSpec& nodes) {
  std::set<int> cores;
  for (const auto& n : nodes.nrt) {
    if (!cores.insert(n.core).second)
      return "two nRT nodes share core " + std::to_string(n.core) +
             ": the guard regulates whatever runs on a core, one budget per core";
    if (n.core == nodes.controller_core)
      return "the controller shares nRT core " + std::to_string(n.core) +
             ": the guard's throttle would hold its own controller";
  }
  return std::nullopt;
}

json guard_config(const std::string& name, const NodesSpec& nodes, const json& regulation,
                  const TunedSetting& t) {
  json reg = {{"policy", "interval"}};
  // The scenario's own keys the guard shares, then the setting's.
  for (const char* k : {"scope", "reclaim", "sharing", "global_budget_mbps"})
    if (regulation.contains(k) && !regulation.at(k).is_null()) reg[k] = regulation.at(k);
  for (std::size_t i = 0; i < t.paths.size(); ++i)
    if (!t.values.at(i).is_null() && t.paths[i] != "regulation.sampling")
      reg[t.paths[i].substr(11)] = t.values.at(i);
  reg["threshold_pct"] = t.threshold_pct;
  reg["reference_mbps"] = std::round(t.reference_mbps * 100.0) / 100.0;
  const std::string policy = reg.at("policy").get<std::string>();
  // Keys of other policies than this one are dropped (the guard refuses them).
  if (policy != "memguard") reg.erase("reclaim"), reg.erase("sharing");
  if (policy != "mempol") reg.erase("global_budget_mbps");
  if (policy == "monolithic" && t.rt_isolation_us) reg["rt_window_us"] = *t.rt_isolation_us;
  json doc = {{"name", valid_name(name)}, {"description", t.description}};
  doc["controller"] = {{"core", nodes.controller_core}};
  doc["rt"] = json::array();
  for (const auto& r : nodes.rt)
    doc["rt"].push_back({{"name", r.name}});
  doc["nrt"] = json::array();
  for (const auto& n : nodes.nrt)
    doc["nrt"].push_back({{"name", n.name}, {"core", n.core}});
  doc["regulation"] = reg;
  return doc;
}

}  // namespace rosguard

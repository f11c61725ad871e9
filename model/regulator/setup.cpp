#include "regulator/setup.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/error.h"
#include "policy/rules.h"

namespace rosguard {

std::unique_ptr<Policy> RegulationSetup::make_policy() const {
  if (!policy.make) throw ContractError("a regulation setup without a policy");
  return policy.make(params);
}

RegulatorConfig RegulationSetup::regulator_config() const {
  RegulatorConfig rc;
  // A point without RT node still has one activation (the engine's).
  rc.rt_count = std::max<std::size_t>(1, nodes.rt);
  rc.account_of_entity = accounts_for_scope(scope, nodes.nrt);
  rc.metric = metric;
  return rc;
}

std::unique_ptr<Regulator> RegulationSetup::make_regulator() const {
  return std::make_unique<Regulator>(regulator_config(), make_policy());
}

std::string RegulationSetup::describe() const {
  std::ostringstream o;
  o << policy.name;
  if (!regulates()) return o.str();
  o << ", " << to_string(sampling) << " sampling";
  if (sampling != Sampling::Overflow)
    o << " every " << static_cast<double>(sampling_period_ns) / kNsPerUs << " us";
  o << ", ";
  if (!params.event_budget_mbps.empty()) {
    o << "budgets per event";
  } else if (params.budget_mbps.empty()) {
    o << params.threshold_pct << " % of " << std::llround(params.reference_mbps) << " MB/s";
  } else {
    o << "budget";
    for (std::size_t i = 0; i < params.budget_mbps.size(); ++i)
      o << (i ? " / " : " ") << params.budget_mbps[i];
    o << " MB/s";
  }
  if (policy.traits.periodic_windows)
    o << " per " << static_cast<double>(params.regulation_period_ns) / kNsPerUs << " us window";
  else
    o << " per RT execution";
  o << ", scope " << to_string(scope);
  return o.str();
}

PolicyParams policy_params(const RegulationSpec& r) {
  PolicyParams p;
  p.threshold_pct = r.threshold_pct;
  p.reference_mbps = r.reference_mbps;
  p.regulation_period_ns = r.regulation_period_us * kNsPerUs;
  p.budget_mbps = r.budget_mbps;
  p.event_budget_mbps = r.event_budget_mbps;
  p.global_budget_mbps = r.global_budget_mbps;
  p.reclaim = r.reclaim;
  p.sharing = r.sharing;
  return p;
}

RegulationSetup regulation_setup(const RegulationSpec& r, RegulatedNodes nodes,
                                 const PolicyRegistry& policies, const std::string& file) {
  const PolicyInfo* info = policies.find(r.policy);
  if (!info) {
    try {
      policies.at(r.policy);
    } catch (const InputError& e) {
      throw InputError(file, e.json_path(), e.message());
    }
  }
  check_policy_rules(r, nodes, info->traits, file);
  RegulationSetup out;
  out.policy = *info;
  out.params = policy_params(r);
  out.sampling = r.sampling;
  out.sampling_period_ns = r.sampling_period_us * kNsPerUs;
  out.scope = r.scope;
  out.metric = r.metric;
  out.nodes = nodes;
  return out;
}

RegulationSetup regulation_setup(const Scenario& s, const PolicyRegistry& policies,
                                 const Baselines* baselines) {
  RegulationSetup out =
      regulation_setup(s.regulation, {s.nodes.rt.size(), s.nodes.nrt.size()}, policies, s.file);
  if (baselines && !s.nodes.rt.empty()) {
    const RtNodeSpec& first = s.nodes.rt.front();
    out.params.monolithic_window_ns = static_cast<TimeNs>(
        std::llround(baselines->at(s, first.workload, first.core).time_us * kNsPerUs));
  }
  return out;
}

}  // namespace rosguard

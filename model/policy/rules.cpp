#include "policy/rules.h"

#include <string>

#include "core/error.h"

namespace rosguard {

void check_policy_rules(const Scenario& s, const PolicyTraits& traits) {
  const RegulationSpec& r = s.regulation;
  if (traits.regulates && traits.periodic_windows && r.sampling_period_us > r.regulation_period_us)
    throw InputError(s.file, "/regulation/sampling_period_us",
                     "sampling period " + std::to_string(r.sampling_period_us) +
                         " us is longer than the regulation period " +
                         std::to_string(r.regulation_period_us) +
                         " us: a budget would be replenished before it could be checked");
  if (traits.throttles && traits.periodic_windows && r.sampling_period_us == r.regulation_period_us)
    throw InputError(s.file, "/regulation/sampling_period_us",
                     "sampling period equals the regulation period (" +
                         std::to_string(r.sampling_period_us) +
                         " us): each window's usage would only be seen as it closes, so nothing "
                         "would ever be throttled; sample more often");
  if (traits.needs_rt && s.nodes.rt.empty())
    throw InputError(s.file, "/regulation/policy",
                     r.policy +
                         " regulation budgets the RT node's execution, and there is no RT "
                         "node");
}

void check_policy(const Scenario& s, const PolicyRegistry& policies) {
  const PolicyInfo* info = policies.find(s.regulation.policy);
  if (!info) {
    try {
      policies.at(s.regulation.policy);
    } catch (const InputError& e) {
      throw InputError(s.file, e.json_path(), e.message());
    }
  }
  check_policy_rules(s, info->traits);
}

}  // namespace rosguard

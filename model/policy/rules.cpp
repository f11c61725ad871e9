#include "policy/rules.h"

#include <algorithm>
#include <string>

#include "core/error.h"

namespace rosguard {
namespace {

// The generic defaults (no policy default of its own): ROSGuard's.
constexpr const char* kDefaultSampling = "self";
constexpr std::int64_t kDefaultSamplingPeriodUs = 1000;
constexpr std::int64_t kDefaultRegulationPeriodUs = 5000;

std::string sampling_list(const std::vector<Sampling>& samplings) {
  std::string out;
  for (Sampling m : samplings)
    out += (out.empty() ? "" : ", ") + std::string(to_string(m));
  return out;
}

}  // namespace

void check_policy_rules(const RegulationSpec& r, RegulatedNodes nodes, const PolicyTraits& traits,
                        const std::string& file) {
  if (traits.regulates && std::find(traits.samplings.begin(), traits.samplings.end(), r.sampling) ==
                              traits.samplings.end())
    throw InputError(file, "/regulation/sampling",
                     r.policy + " regulation does not run with " +
                         std::string(to_string(r.sampling)) +
                         " sampling (it runs with: " + sampling_list(traits.samplings) + ")");
  // Overflow sampling has no sampling period: the interrupt fires at the budget crossing.
  const bool periodic_sampling = r.sampling != Sampling::Overflow;
  if (traits.regulates && traits.periodic_windows && periodic_sampling &&
      r.sampling_period_us > r.regulation_period_us)
    throw InputError(file, "/regulation/sampling_period_us",
                     "sampling period " + std::to_string(r.sampling_period_us) +
                         " us is longer than the regulation period " +
                         std::to_string(r.regulation_period_us) +
                         " us: a budget would be replenished before it could be checked");
  if (traits.throttles && traits.periodic_windows && periodic_sampling &&
      r.sampling_period_us == r.regulation_period_us)
    throw InputError(file, "/regulation/sampling_period_us",
                     "sampling period equals the regulation period (" +
                         std::to_string(r.sampling_period_us) +
                         " us): each window's usage would only be seen as it closes, so nothing "
                         "would ever be throttled; sample more often");
  if (traits.needs_rt && nodes.rt == 0)
    throw InputError(file, "/regulation/policy",
                     r.policy +
                         " regulation budgets the RT node's execution, and there is no RT "
                         "node");
  if (r.reclaim && !traits.reclaim)
    throw InputError(file, "/regulation/reclaim",
                     r.policy + " regulation has no budget reclaim (memguard has)");
  if (r.sharing != Sharing::Off && !traits.reclaim)
    throw InputError(file, "/regulation/sharing",
                     r.policy + " regulation has no sharing of spare bandwidth (memguard has)");
  if (r.global_budget_mbps > 0 && !traits.global_budget)
    throw InputError(file, "/regulation/global_budget_mbps",
                     r.policy + " regulation has no global budget (mempol has)");
  if (!traits.regulates && (!r.budget_mbps.empty() || !r.event_budget_mbps.empty()))
    throw InputError(
        file, r.budget_mbps.empty() ? "/regulation/event_budget_mbps" : "/regulation/budget_mbps",
        r.policy + " regulation has no budget: the key would be ignored");
  if (r.sampling == Sampling::Overflow && r.scope == Scope::Group && nodes.nrt > 1)
    throw InputError(file, "/regulation/scope",
                     "overflow sampling arms each core's PMU with its own budget; scope group "
                     "shares one budget between cores, which no core's interrupt can see (use "
                     "scope core or node)");
}

std::vector<std::string> apply_policy_defaults(nlohmann::json& regulation) {
  std::vector<std::string> applied;
  if (!regulation.is_object()) return applied;
  const std::string policy = regulation.contains("policy") && regulation.at("policy").is_string()
                                 ? regulation.at("policy").get<std::string>()
                                 : std::string("interval");
  const PolicyInfo* info = find_builtin_policy(policy);
  const auto fill = [&](const char* key, const nlohmann::json& own, const nlohmann::json& generic) {
    if (regulation.contains(key)) return;
    if (own.is_null()) {
      regulation[key] = generic;
      return;
    }
    regulation[key] = own;
    applied.push_back(std::string(key) + " = " +
                      (own.is_string() ? own.get<std::string>() : own.dump()) + " (" + policy +
                      "'s default)");
  };
  nlohmann::json sampling, sampling_period, regulation_period;
  if (info && info->traits.regulates) {
    if (info->traits.samplings.front() != Sampling::Self)
      sampling = std::string(to_string(info->traits.samplings.front()));
    if (info->traits.default_sampling_period_us > 0)
      sampling_period = info->traits.default_sampling_period_us;
    if (info->traits.default_regulation_period_us > 0)
      regulation_period = info->traits.default_regulation_period_us;
  }
  fill("sampling", sampling, kDefaultSampling);
  fill("sampling_period_us", sampling_period, kDefaultSamplingPeriodUs);
  fill("regulation_period_us", regulation_period, kDefaultRegulationPeriodUs);
  return applied;
}

}  // namespace rosguard

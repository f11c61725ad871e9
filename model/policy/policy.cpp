#include "policy/policy.h"

#include <stdexcept>

#include "core/error.h"

namespace rosguard {

void open_accounts(std::span<Account> accounts, TimeNs start, double budget) {
  for (Account& a : accounts) {
    a.budget_bytes = budget;
    a.used_bytes = 0.0;
    a.window_start = start;
    a.throttled = false;
  }
}

const PolicyInfo& PolicyRegistry::at(std::string_view name) const {
  if (const PolicyInfo* info = find(name)) return *info;
  std::string known;
  for (const auto& p : all())
    known += (known.empty() ? "" : ", ") + p.name;
  throw InputError("", "/regulation/policy",
                   "unknown policy '" + std::string(name) + "' (known: " + known + ")");
}

std::unique_ptr<Policy> PolicyRegistry::make(std::string_view name,
                                             const PolicyParams& params) const {
  return at(name).make(params);
}

const std::vector<PolicyInfo>& builtin_policies() {
  static const std::vector<PolicyInfo> policies = {
      {"interval",
       "budget per regulation period, replenished at every boundary (ROSGuard default)",
       {.regulates = true, .throttles = true, .periodic_windows = true, .needs_rt = false},
       make_interval_policy},
      {"monolithic",
       "one budget for the whole RT execution; throttled until the RT node finishes",
       {.regulates = true, .throttles = true, .periodic_windows = false, .needs_rt = true},
       make_monolithic_policy},
      {"monitor",
       "sample and account, never throttle (measures sampling overhead)",
       {.regulates = true, .throttles = false, .periodic_windows = true, .needs_rt = false},
       make_monitor_policy},
      {"none",
       "no regulation at all (unregulated co-run baseline)",
       {.regulates = false, .throttles = false, .periodic_windows = false, .needs_rt = false},
       make_none_policy},
  };
  return policies;
}

const PolicyInfo* find_builtin_policy(std::string_view name) {
  for (const auto& p : builtin_policies())
    if (p.name == name) return &p;
  return nullptr;
}

void register_builtin(PolicyRegistry& registry) {
  for (const auto& p : builtin_policies())
    registry.add(p);
}

}  // namespace rosguard

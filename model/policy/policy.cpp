#include "policy/policy.h"

#include <stdexcept>

namespace rosguard {

void open_accounts(std::span<Account> accounts, TimeNs start, double budget) {
  for (Account& a : accounts) {
    a.budget_bytes = budget;
    a.used_bytes = 0.0;
    a.window_start = start;
    a.throttled = false;
  }
}

std::unique_ptr<Policy> PolicyRegistry::make(std::string_view name,
                                             const PolicyParams& params) const {
  if (const PolicyInfo* info = find(name)) return info->make(params);
  std::string known;
  for (const auto& p : all())
    known += (known.empty() ? "" : ", ") + p.name;
  throw std::out_of_range("unknown policy '" + std::string(name) + "' (known: " + known + ")");
}

void register_builtin(PolicyRegistry& registry) {
  registry.add({"interval",
                "budget per regulation period, replenished at every boundary (ROSGuard default)",
                make_interval_policy});
  registry.add({"monolithic",
                "one budget for the whole RT execution; throttled until the RT node finishes",
                make_monolithic_policy});
  registry.add({"monitor", "sample and account, never throttle (measures sampling overhead)",
                make_monitor_policy});
  registry.add({"none", "no regulation at all (unregulated co-run baseline)", make_none_policy});
}

}  // namespace rosguard

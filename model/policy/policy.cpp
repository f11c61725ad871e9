#include "policy/policy.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "core/error.h"
#include "metric/metric.h"

namespace rosguard {

void open_accounts(std::span<Account> accounts, TimeNs start, double budget) {
  for (Account& a : accounts) {
    a.budget_bytes = budget;
    a.assigned_bytes = budget;
    a.used_bytes = 0.0;
    a.window_start = start;
    a.throttled = false;
    a.shortfall = false;
    a.event_budget_bytes.clear();
    a.event_used_bytes.clear();
  }
}

double account_rate_mbps(const PolicyParams& p, std::size_t account) {
  if (p.budget_mbps.empty()) return p.threshold_pct / 100.0 * p.reference_mbps;
  if (p.budget_mbps.size() == 1) return p.budget_mbps.front();
  if (account >= p.budget_mbps.size())
    throw ContractError("no budget_mbps for account " + std::to_string(account) + " (" +
                        std::to_string(p.budget_mbps.size()) + " given)");
  return p.budget_mbps[account];
}

void open_budgeted(std::span<Account> accounts, TimeNs start, const PolicyParams& p,
                   TimeNs length_ns) {
  constexpr double kUnlimited = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < accounts.size(); ++i) {
    Account& a = accounts[i];
    const double total = p.event_budget_mbps.empty()
                             ? budget_bytes(100.0, account_rate_mbps(p, i), length_ns)
                             : kUnlimited;
    open_accounts(accounts.subspan(i, 1), start, total);
    a.event_budget_bytes.clear();
    for (double mbps : p.event_budget_mbps)
      a.event_budget_bytes.push_back(std::isfinite(mbps) ? budget_bytes(100.0, mbps, length_ns)
                                                         : kUnlimited);
    a.event_used_bytes.assign(p.event_budget_mbps.size(), 0.0);
  }
}

bool exceeds_budget(const Account& a) {
  if (a.used_bytes > a.budget_bytes) return true;
  for (std::size_t i = 0; i < a.event_budget_bytes.size() && i < a.event_used_bytes.size(); ++i)
    if (a.event_used_bytes[i] > a.event_budget_bytes[i]) return true;
  return false;
}

void Policy::open_period(TimeNs start, std::span<Account> accounts, GlobalAccount& global,
                         bool) const {
  open_window(start, accounts);
  global = GlobalAccount{};
}

Verdict Policy::judge(std::size_t index, std::span<Account> accounts, GlobalAccount&) const {
  return over_budget(accounts[index]) ? Verdict::ThrottleAccount : Verdict::Keep;
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
      {"memguard",
       "MemGuard (Yun et al., RTAS 2013): per-core budget per period (1 ms), a PMU overflow "
       "interrupt throttles the core at once, optional reclaim and sharing",
       {.regulates = true,
        .throttles = true,
        .periodic_windows = true,
        .needs_rt = false,
        .samplings = {Sampling::Overflow, Sampling::External, Sampling::Self},
        .default_regulation_period_us = 1000,
        .default_sampling_period_us = 200,
        .reclaim = true},
       make_memguard_policy},
      {"mempol",
       "MemPol (Zuepke et al., RTAS 2023): the controller core polls the cores' counters through "
       "debug registers every few us; per-core shares plus a global cap",
       {.regulates = true,
        .throttles = true,
        .periodic_windows = true,
        .needs_rt = false,
        .samplings = {Sampling::Mmio, Sampling::External},
        .default_regulation_period_us = 1000,
        .default_sampling_period_us = 5,
        .global_budget = true},
       make_mempol_policy},
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

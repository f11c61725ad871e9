// Regulation policies: how budgets are sized and when they are replenished.
//
// Contract: a Policy is owned by one Regulator and called only from its methods (one thread at a
// time). It keeps no per-run state of its own: everything that changes lives in the Account
// objects the regulator passes in, so one policy object could serve several regulators.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/registry.h"
#include "core/types.h"

namespace rosguard {

// Budget accounting of one account (one per core or node, or one for the whole group).
struct Account {
  double budget_bytes = 0.0;  // allowed in the current window
  double used_bytes = 0.0;    // consumed in the current window
  TimeNs window_start = 0;    // start of the current window
  std::uint64_t window = 0;   // index of the current window since the activation began
  bool throttled = false;     // THR was sent in this window
};

struct PolicyParams {
  double threshold_pct = 0.0;       // (0, 100]
  double reference_mbps = 0.0;      // Eq. 1 MB/s that threshold_pct is a percentage of
  TimeNs regulation_period_ns = 0;  // interval / monitor window
  TimeNs monolithic_window_ns = 0;  // monolithic: the RT node's isolation time
};

class Policy {
 public:
  virtual ~Policy() = default;

  virtual std::string_view name() const = 0;
  // false: the regulator stays silent (no ON / OFF, no accounting): the unregulated co-run.
  virtual bool regulates() const { return true; }
  // Set up every account for a window starting at `start` (activation or boundary).
  virtual void open_window(TimeNs start, std::span<Account> accounts) const = 0;
  // Whether an account must be throttled given its usage so far in the window.
  virtual bool over_budget(const Account& account) const = 0;
  // End of the window that started at `start`, or nullopt when it lasts until the RT node(s)
  // finish.
  virtual std::optional<TimeNs> window_end(TimeNs start) const = 0;
};

// Starts a fresh window on every account: `budget` bytes, nothing used, not throttled.
void open_accounts(std::span<Account> accounts, TimeNs start, double budget);

using PolicyFactory = std::function<std::unique_ptr<Policy>(const PolicyParams&)>;

// What a policy is, known without its parameters. Scenario checks and the backends ask these
// instead of comparing policy names.
struct PolicyTraits {
  bool regulates = true;         // false: no ON / OFF, no sampling: the unregulated co-run
  bool throttles = true;         // false: samples and accounts, never throttles (monitor)
  bool periodic_windows = true;  // a budget per regulation period; false: one per RT execution
  bool needs_rt = false;         // the budget is sized from the first RT node's isolation time
};

struct PolicyInfo {
  std::string name;
  std::string description;
  PolicyTraits traits;
  PolicyFactory make;
};

// Policies by name.
class PolicyRegistry : public Registry<PolicyInfo> {
 public:
  PolicyRegistry() : Registry("policy") {}
  // Throws InputError (/regulation/policy) naming the known policies.
  const PolicyInfo& at(std::string_view name) const;
  std::unique_ptr<Policy> make(std::string_view name, const PolicyParams& params) const;
};

// The built-in policies, defined once: interval, monolithic, monitor and none.
const std::vector<PolicyInfo>& builtin_policies();
// A built-in policy by name, or null.
const PolicyInfo* find_builtin_policy(std::string_view name);
// Adds the built-in policies.
void register_builtin(PolicyRegistry& registry);

// The built-in policies, also usable without a registry (tests, benchmarks).
std::unique_ptr<Policy> make_interval_policy(const PolicyParams& params);
std::unique_ptr<Policy> make_monolithic_policy(const PolicyParams& params);
std::unique_ptr<Policy> make_monitor_policy(const PolicyParams& params);
std::unique_ptr<Policy> make_none_policy(const PolicyParams& params);

}  // namespace rosguard

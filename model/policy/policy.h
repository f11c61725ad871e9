// Regulation policies: how budgets are sized and when they are replenished.
//
// Contract: a Policy is owned by one Regulator and called only from its methods (one thread at a
// time). It keeps no per-run state of its own: everything that changes lives in the Account
// objects the regulator passes in, so one policy object could serve several regulators.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
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
  double budget_bytes = 0.0;  // allowed in the current window (after donation / reclaim)
  double used_bytes = 0.0;    // consumed in the current window
  TimeNs window_start = 0;    // start of the current window
  std::uint64_t window = 0;   // index of the current window since the activation began
  bool throttled = false;     // THR was sent in this window
  // Per-event budgets, in the metric's event order (empty: none; +inf: that event is not
  // budgeted). Where given they replace the total budget (budget_bytes is then +inf).
  std::vector<double> event_budget_bytes;
  std::vector<double> event_used_bytes;  // consumed per event in the current window
  // MemGuard's reclaim (policy/memguard.cpp): the account's own reservation this window, before
  // it donated part of it, and the predictor's estimate of its usage (< 0: no estimate yet).
  double assigned_bytes = 0.0;
  double predicted_bytes = -1.0;
  bool shortfall = false;  // it donated more than it could take back this window
};

// What every account shares: MemPol's global cap, MemGuard's pool of donated budget, and the
// sharing state of the window. Reset by the policy at every window.
struct GlobalAccount {
  double cap_bytes = std::numeric_limits<double>::infinity();  // all accounts together
  double used_bytes = 0.0;  // all accounts' usage in the current window
  double pool_bytes = 0.0;  // donated budget not yet reclaimed
  bool capped = false;      // the cap was exceeded: every entity throttled until the window ends
  bool released = false;    // MemGuard sharing: no throttling for the rest of the window
};

// What the regulator does after usage was charged to an account.
enum class Verdict : std::uint8_t {
  Keep,             // nothing
  ThrottleAccount,  // THR to the account's entities that are ON
  ThrottleAll,      // THR to every entity that is ON (a global cap)
  ReleaseAll,       // REPLENISH every throttled entity; no THR until the window ends
};

struct PolicyParams {
  double threshold_pct = 0.0;       // (0, 100]
  double reference_mbps = 0.0;      // Eq. 1 MB/s that threshold_pct is a percentage of
  TimeNs regulation_period_ns = 0;  // interval / monitor / memguard / mempol window
  TimeNs monolithic_window_ns = 0;  // monolithic: the RT node's isolation time
  // Absolute budgets in MB/s of Eq. 1 (MiB/s). Empty: threshold_pct % of reference_mbps for
  // every account; one value: that for every account; one per account: each its own.
  std::vector<double> budget_mbps{};
  // Per metric event (in the metric's order; +inf: not budgeted). Empty: no per-event budgets.
  // Given, they replace the total budget of every account.
  std::vector<double> event_budget_mbps{};
  double global_budget_mbps = 0.0;  // MemPol: all accounts together; 0: no global cap
  bool reclaim = false;             // MemGuard: donate the predicted surplus, reclaim on demand
  Sharing sharing = Sharing::Off;   // MemGuard: what happens when every core is exhausted
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
  // The whole ledger at a window start (activation: `fresh`, no history of this activation; or a
  // boundary, the accounts still holding the closed window's usage). Default: open_window() on
  // the accounts and a fresh global account (no cap, empty pool).
  virtual void open_period(TimeNs start, std::span<Account> accounts, GlobalAccount& global,
                           bool fresh) const;
  // After usage was charged to accounts[index] (and to global.used_bytes), while that account is
  // not throttled: what to do. May change the ledger (a reclaim grows the account's budget).
  // Default: ThrottleAccount when over_budget(), else Keep.
  virtual Verdict judge(std::size_t index, std::span<Account> accounts,
                        GlobalAccount& global) const;
  // End of the window that started at `start`, or nullopt when it lasts until the RT node(s)
  // finish.
  virtual std::optional<TimeNs> window_end(TimeNs start) const = 0;
};

// The budget rate of `account` in MB/s: budget_mbps where given, else threshold_pct % of
// reference_mbps.
double account_rate_mbps(const PolicyParams& p, std::size_t account);

// Whether an account used more than its budget: strictly more than the total, or than any of its
// per-event budgets.
bool exceeds_budget(const Account& a);

// Starts a fresh window on every account: `budget` bytes, nothing used, not throttled.
void open_accounts(std::span<Account> accounts, TimeNs start, double budget);
// Starts a fresh window of `length_ns` on every account, sized from `p`: account_rate_mbps(),
// or p.event_budget_mbps per event when given (the total is then unlimited).
void open_budgeted(std::span<Account> accounts, TimeNs start, const PolicyParams& p,
                   TimeNs length_ns);

using PolicyFactory = std::function<std::unique_ptr<Policy>(const PolicyParams&)>;

// What a policy is, known without its parameters. Scenario checks and the backends ask these
// instead of comparing policy names.
struct PolicyTraits {
  bool regulates = true;         // false: no ON / OFF, no sampling: the unregulated co-run
  bool throttles = true;         // false: samples and accounts, never throttles (monitor)
  bool periodic_windows = true;  // a budget per regulation period; false: one per RT execution
  bool needs_rt = false;         // the budget is sized from the first RT node's isolation time
  // The sampling modes it runs with; the first is its default (regulation.sampling unset).
  std::vector<Sampling> samplings = {Sampling::Self, Sampling::External};
  // Its defaults where the scenario does not set the key (0: the schema's own default).
  std::int64_t default_regulation_period_us = 0;
  std::int64_t default_sampling_period_us = 0;
  bool reclaim = false;        // accepts regulation.reclaim and regulation.sharing (MemGuard)
  bool global_budget = false;  // accepts regulation.global_budget_mbps (MemPol)
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

// The built-in policies, defined once: interval, monolithic, monitor, none, memguard, mempol.
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
std::unique_ptr<Policy> make_memguard_policy(const PolicyParams& params);
std::unique_ptr<Policy> make_mempol_policy(const PolicyParams& params);

}  // namespace rosguard

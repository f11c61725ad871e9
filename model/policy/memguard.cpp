// MemGuard (Yun, Yao, Pellizzoni, Caccamo, Sha: "MemGuard: Memory Bandwidth Reservation System
// for Efficient Performance Isolation in Multi-core Platforms", RTAS 2013; "Memory Bandwidth
// Management for Efficient Performance Isolation in Multi-Core Platforms", IEEE TC 2016; the
// memguard kernel module, github.com/heechul/memguard).
//
// Rules, per regulation period (1 ms by default, the module's g_period_us):
// - every core (account) has a reservation: its budget_mbps, or threshold_pct % of the reference,
//   scaled to the period; separate read / write budgets are per-event budgets on the metric's
//   events (e.g. l2d_cache_refill for reads, l2d_cache_wb for write-backs);
// - exceeding the budget throttles the core at once (the host delivers the overflow interrupt at
//   the crossing: Sampling::Overflow) until the period ends;
// - reclaim (optional): at each period start a core predicts its usage (the module's predictor:
//   an exponentially weighted average with a = 1/2 of the usage of past periods); if the
//   prediction is below its reservation it donates the difference to a global pool and keeps the
//   prediction as its budget. A core that exhausts its budget first takes back what it donated
//   (its reservation is guaranteed: if the pool no longer holds it, it gets it anyway, counted as
//   a shortfall, and the predictor is set to the reservation for the next period, as the
//   module's "throttle error" compensation does), then reclaims from the pool at most one
//   reservation's worth per exhaustion; with the pool empty it is throttled;
// - sharing (optional): when every regulated core has exhausted its budget, `last` lets the last
//   one run on until the period ends (the module's g_use_exclusive 1), `all` releases every core
//   until the period ends (g_use_exclusive 2). The RT cores are not regulated here (ROSGuard's
//   setting), so "every core" means every nRT account.
#include <algorithm>
#include <stdexcept>
#include <string>

#include "core/error.h"
#include "metric/metric.h"
#include "policy/policy.h"

namespace rosguard {
namespace {

class MemguardPolicy : public Policy {
 public:
  explicit MemguardPolicy(const PolicyParams& p) : period_ns_(p.regulation_period_ns), params_(p) {}

  std::string_view name() const override { return "memguard"; }

  void open_window(TimeNs start, std::span<Account> accounts) const override {
    open_budgeted(accounts, start, params_, period_ns_);
  }

  void open_period(TimeNs start, std::span<Account> accounts, GlobalAccount& global,
                   bool fresh) const override {
    // The predictor learns from the window that just closed (the accounts still hold it).
    std::vector<double> predicted(accounts.size(), -1.0);
    if (params_.reclaim && !fresh)
      for (std::size_t i = 0; i < accounts.size(); ++i) {
        const Account& a = accounts[i];
        predicted[i] = a.shortfall             ? a.assigned_bytes
                       : a.predicted_bytes < 0 ? a.used_bytes
                                               : 0.5 * a.predicted_bytes + 0.5 * a.used_bytes;
      }
    open_window(start, accounts);
    global = GlobalAccount{};
    for (std::size_t i = 0; i < accounts.size(); ++i) {
      Account& a = accounts[i];
      a.predicted_bytes = predicted[i];
      // Per-event budgets are not donated: the module's predictor is on its one counter.
      if (!params_.reclaim || predicted[i] < 0 || !a.event_budget_bytes.empty()) continue;
      if (predicted[i] < a.assigned_bytes) {
        // A budget of zero would raise the interrupt at once: at least one line, as the module
        // keeps at least one event.
        const double keep = std::max(predicted[i], 64.0);
        if (keep < a.assigned_bytes) {
          global.pool_bytes += a.assigned_bytes - keep;
          a.budget_bytes = keep;
        }
      }
    }
  }

  bool over_budget(const Account& a) const override { return exceeds_budget(a); }

  Verdict judge(std::size_t index, std::span<Account> accounts,
                GlobalAccount& global) const override {
    if (global.released) return Verdict::Keep;
    Account& a = accounts[index];
    if (params_.reclaim)
      while (a.used_bytes > a.budget_bytes) {
        if (a.budget_bytes < a.assigned_bytes) {
          // Its own donation back first: the reservation is guaranteed.
          const double owed = a.assigned_bytes - a.budget_bytes;
          const double back = std::min(owed, global.pool_bytes);
          global.pool_bytes -= back;
          if (back < owed) a.shortfall = true;
          a.budget_bytes = a.assigned_bytes;
          continue;
        }
        const double grant = std::min(global.pool_bytes, a.assigned_bytes);
        if (grant <= 0.0) break;
        global.pool_bytes -= grant;
        a.budget_bytes += grant;
      }
    if (!exceeds_budget(a)) return Verdict::Keep;
    if (params_.sharing != Sharing::Off) {
      bool others_throttled = true;
      for (std::size_t i = 0; i < accounts.size(); ++i)
        if (i != index && !accounts[i].throttled) others_throttled = false;
      if (others_throttled) {
        global.released = true;
        return params_.sharing == Sharing::Last ? Verdict::Keep : Verdict::ReleaseAll;
      }
    }
    return Verdict::ThrottleAccount;
  }

  std::optional<TimeNs> window_end(TimeNs start) const override { return start + period_ns_; }

 private:
  TimeNs period_ns_;
  PolicyParams params_;
};

}  // namespace

std::unique_ptr<Policy> make_memguard_policy(const PolicyParams& params) {
  if (params.regulation_period_ns <= 0)
    throw ContractError("memguard policy: the regulation period must be positive, not " +
                        std::to_string(params.regulation_period_ns) + " ns");
  return std::make_unique<MemguardPolicy>(params);
}

}  // namespace rosguard

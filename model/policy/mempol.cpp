// MemPol (Zuepke, Bastoni, Chen, Caccamo, Mancuso: "MemPol: Policing Core Memory Bandwidth from
// Outside of the Cores", RTAS 2023): a dedicated core polls the regulated cores' PMU counters
// through their memory-mapped debug registers every few microseconds (Sampling::Mmio) and halts a
// core through the same interface, so nothing runs on the regulated cores.
//
// Rules, per regulation period: every core (account) has its share (budget_mbps, or
// threshold_pct % of the reference, scaled to the period) and is halted when it used more than
// it; all regulated cores together also have a global cap (global_budget_mbps scaled to the
// period): when their summed usage exceeds it, every core is halted until the period ends.
#include <stdexcept>
#include <string>

#include "core/error.h"
#include "metric/metric.h"
#include "policy/policy.h"

namespace rosguard {
namespace {

class MempolPolicy : public Policy {
 public:
  explicit MempolPolicy(const PolicyParams& p) : period_ns_(p.regulation_period_ns), params_(p) {}

  std::string_view name() const override { return "mempol"; }

  void open_window(TimeNs start, std::span<Account> accounts) const override {
    open_budgeted(accounts, start, params_, period_ns_);
  }

  void open_period(TimeNs start, std::span<Account> accounts, GlobalAccount& global,
                   bool) const override {
    open_window(start, accounts);
    global = GlobalAccount{};
    if (params_.global_budget_mbps > 0)
      global.cap_bytes = budget_bytes(100.0, params_.global_budget_mbps, period_ns_);
  }

  bool over_budget(const Account& a) const override { return exceeds_budget(a); }

  Verdict judge(std::size_t index, std::span<Account> accounts,
                GlobalAccount& global) const override {
    if (global.used_bytes > global.cap_bytes) {
      global.capped = true;
      return Verdict::ThrottleAll;
    }
    return exceeds_budget(accounts[index]) ? Verdict::ThrottleAccount : Verdict::Keep;
  }

  std::optional<TimeNs> window_end(TimeNs start) const override { return start + period_ns_; }

 private:
  TimeNs period_ns_;
  PolicyParams params_;
};

}  // namespace

std::unique_ptr<Policy> make_mempol_policy(const PolicyParams& params) {
  if (params.regulation_period_ns <= 0)
    throw ContractError("mempol policy: the regulation period must be positive, not " +
                        std::to_string(params.regulation_period_ns) + " ns");
  if (params.global_budget_mbps < 0)
    throw ContractError("mempol policy: the global budget must not be negative");
  return std::make_unique<MempolPolicy>(params);
}

}  // namespace rosguard

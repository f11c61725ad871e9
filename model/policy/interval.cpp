// Interval policy: the ROSGuard default. The budget of each regulation period is the threshold
// scaled to the period; it is replenished at every period boundary.
#include <stdexcept>
#include <string>

#include "core/error.h"
#include "metric/metric.h"
#include "policy/policy.h"

namespace rosguard {
namespace {

class IntervalPolicy : public Policy {
 public:
  explicit IntervalPolicy(const PolicyParams& p) : period_ns_(p.regulation_period_ns), params_(p) {}

  std::string_view name() const override { return "interval"; }

  void open_window(TimeNs start, std::span<Account> accounts) const override {
    open_budgeted(accounts, start, params_, period_ns_);
  }

  bool over_budget(const Account& a) const override { return exceeds_budget(a); }

  std::optional<TimeNs> window_end(TimeNs start) const override { return start + period_ns_; }

 private:
  TimeNs period_ns_;
  PolicyParams params_;
};

}  // namespace

std::unique_ptr<Policy> make_interval_policy(const PolicyParams& params) {
  // A window that ends where it starts would never let the regulator's catch-up loop finish.
  if (params.regulation_period_ns <= 0)
    throw ContractError("interval policy: the regulation period must be positive, not " +
                        std::to_string(params.regulation_period_ns) + " ns");
  return std::make_unique<IntervalPolicy>(params);
}

}  // namespace rosguard

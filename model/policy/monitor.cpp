// Monitor policy: entities are switched ON (so self-sampling runs and costs what it costs) and
// usage is accounted per regulation period, but nothing is ever throttled. Used to measure the
// sampling overhead (experiment 2 of the paper).
#include <stdexcept>
#include <string>

#include "core/error.h"
#include "metric/metric.h"
#include "policy/policy.h"

namespace rosguard {
namespace {

class MonitorPolicy : public Policy {
 public:
  explicit MonitorPolicy(const PolicyParams& p) : period_ns_(p.regulation_period_ns), params_(p) {}

  std::string_view name() const override { return "monitor"; }

  void open_window(TimeNs start, std::span<Account> accounts) const override {
    open_budgeted(accounts, start, params_, period_ns_);
  }

  bool over_budget(const Account&) const override { return false; }

  std::optional<TimeNs> window_end(TimeNs start) const override { return start + period_ns_; }

 private:
  TimeNs period_ns_;
  PolicyParams params_;
};

}  // namespace

std::unique_ptr<Policy> make_monitor_policy(const PolicyParams& params) {
  // A window that ends where it starts would never let the regulator's catch-up loop finish.
  if (params.regulation_period_ns <= 0)
    throw ContractError("monitor policy: the regulation period must be positive, not " +
                        std::to_string(params.regulation_period_ns) + " ns");
  return std::make_unique<MonitorPolicy>(params);
}

}  // namespace rosguard

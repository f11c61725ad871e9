// Monolithic policy: one budget for the whole RT execution window (the threshold times the
// reference bandwidth times the RT node's isolation time). Once exceeded, the entity stays
// throttled until the last RT node finishes (OFF).
#include <stdexcept>
#include <string>

#include "core/error.h"
#include "metric/metric.h"
#include "policy/policy.h"

namespace rosguard {
namespace {

class MonolithicPolicy : public Policy {
 public:
  explicit MonolithicPolicy(const PolicyParams& p) : params_(p) {}

  std::string_view name() const override { return "monolithic"; }

  void open_window(TimeNs start, std::span<Account> accounts) const override {
    open_budgeted(accounts, start, params_, params_.monolithic_window_ns);
  }

  bool over_budget(const Account& a) const override { return exceeds_budget(a); }

  std::optional<TimeNs> window_end(TimeNs) const override { return std::nullopt; }

 private:
  PolicyParams params_;
};

}  // namespace

std::unique_ptr<Policy> make_monolithic_policy(const PolicyParams& params) {
  // The window is the RT node's isolation time; without it the budget would be zero.
  if (params.monolithic_window_ns <= 0)
    throw ContractError("monolithic policy: the RT execution window must be positive, not " +
                        std::to_string(params.monolithic_window_ns) + " ns");
  return std::make_unique<MonolithicPolicy>(params);
}

}  // namespace rosguard

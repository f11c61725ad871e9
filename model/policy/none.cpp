// No regulation: the regulator sends nothing and accounts nothing. The co-run baseline.
#include "policy/policy.h"

namespace rosguard {
namespace {

class NonePolicy : public Policy {
 public:
  std::string_view name() const override { return "none"; }
  bool regulates() const override { return false; }
  void open_window(TimeNs, std::span<Account>) const override {}
  bool over_budget(const Account&) const override { return false; }
  std::optional<TimeNs> window_end(TimeNs) const override { return std::nullopt; }
};

}  // namespace

std::unique_ptr<Policy> make_none_policy(const PolicyParams&) {
  return std::make_unique<NonePolicy>();
}

}  // namespace rosguard

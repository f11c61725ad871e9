// Test support for the regulator core: readable command sequences in Catch output and a small
// rig that keeps cumulative counters per entity, as a host would.
#pragma once

#include <catch2/catch.hpp>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/types.h"
#include "metric/metric.h"
#include "node/nrt_node.h"
#include "policy/policy.h"
#include "regulator/regulator.h"

namespace Catch {
template <>
struct StringMaker<rosguard::CommandOut> {
  static std::string convert(const rosguard::CommandOut& c) {
    return "{" + std::to_string(c.t) + " ns, e" + std::to_string(c.entity) + ", " +
           std::string(rosguard::to_string(c.command)) + "}";
  }
};
template <>
struct StringMaker<rosguard::NodeState> {
  static std::string convert(rosguard::NodeState s) { return std::string(rosguard::to_string(s)); }
};
}  // namespace Catch

namespace rosguard::test {

// The commands, short, as the tests write their expected sequences.
constexpr auto On = Command::On;
constexpr auto Off = Command::Off;
constexpr auto Thr = Command::Thr;
constexpr auto Rep = Command::Replenish;

constexpr TimeNs ms(std::int64_t v) {
  return v * kNsPerMs;
}
constexpr TimeNs us(std::int64_t v) {
  return v * kNsPerUs;
}

// The reference setup of these tests, chosen so that budgets are whole numbers of lines:
// threshold 20 %, reference 1000 MB/s, regulation period 5 ms gives
//   budget = 20/100 x 1000 x 1024 x 1024 B/s x 0.005 s = 1 048 576 B = 16 384 lines of 64 B.
constexpr double kThresholdPct = 20.0;
constexpr double kReferenceMbps = 1000.0;
constexpr TimeNs kPeriod = ms(5);
constexpr double kBudgetBytes = 1048576.0;
constexpr std::uint64_t kBudgetLines = 16384;

inline PolicyParams params(TimeNs period = kPeriod, TimeNs monolithic_window = 0,
                           double threshold_pct = kThresholdPct) {
  PolicyParams p;
  p.threshold_pct = threshold_pct;
  p.reference_mbps = kReferenceMbps;
  p.regulation_period_ns = period;
  p.monolithic_window_ns = monolithic_window;
  return p;
}

// A regulator plus the cumulative counters of its entities (default metric: two events, 64-byte
// lines). Counters are never multiplexed unless a test sets the times itself.
struct Rig {
  Regulator reg;
  Commands out;
  std::vector<std::vector<CounterValue>> counters;

  Rig(std::unique_ptr<Policy> policy, std::size_t entities, Scope scope = Scope::Core,
      std::size_t rt_count = 1, MetricSpec metric = {})
      : reg(RegulatorConfig{rt_count, accounts_for_scope(scope, entities), metric},
            std::move(policy)),
        counters(entities, std::vector<CounterValue>(metric.events.size())) {}

  // Adds `lines` to the first event of entity `e` and samples every event of it at `t`.
  void sample(TimeNs t, std::size_t e, std::uint64_t lines) {
    auto& c = counters.at(e);
    c[0].value += lines;
    for (auto& v : c) {
      v.time_enabled_ns = static_cast<std::uint64_t>(t);
      v.time_running_ns = static_cast<std::uint64_t>(t);
    }
    reg.sample(t, e, c, out);
  }

  // The commands emitted since the last take().
  Commands take() {
    Commands c = std::move(out);
    out.clear();
    return c;
  }
};

}  // namespace rosguard::test

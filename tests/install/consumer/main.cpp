// Regulates one nRT entity with the installed regulator core and the interval policy: the
// entity is switched ON when the RT node starts, throttled once its usage passes the window's
// budget, replenished at the window boundary, and switched OFF when the RT node finishes.
#include <rosguard/core/types.h>
#include <rosguard/metric/metric.h>
#include <rosguard/policy/policy.h>
#include <rosguard/regulator/regulator.h>

#include <cstdint>
#include <iostream>

int main() {
  using namespace rosguard;
  PolicyRegistry policies;
  register_builtin(policies);
  const PolicyParams params{
      .threshold_pct = 10.0, .reference_mbps = 1000.0, .regulation_period_ns = kNsPerMs};
  RegulatorConfig config;
  config.account_of_entity = accounts_for_scope(Scope::Core, 1);
  Regulator regulator(config, policies.make("interval", params));

  Commands out;
  regulator.rt_started(0, 0, out);
  const CounterValue baseline[2] = {};
  regulator.sample(0, 0, baseline, out);
  // 0.6 ms later the entity has refilled twice its 1 ms budget in 64-byte lines.
  const double budget = budget_bytes(params.threshold_pct, params.reference_mbps, kNsPerMs);
  const auto lines = static_cast<std::uint64_t>(2.0 * budget / 64.0);
  const CounterValue later[2] = {{lines, 600'000, 600'000}, {0, 600'000, 600'000}};
  regulator.sample(600'000, 0, later, out);
  regulator.tick(regulator.next_tick().value(), out);
  regulator.rt_finished(1'500'000, 0, out);

  std::cout << "budget per window: " << static_cast<std::uint64_t>(budget) << " bytes\n";
  for (const CommandOut& c : out)
    std::cout << c.t << " ns: entity " << c.entity << " " << to_string(c.command) << "\n";
  std::cout << "throttles: " << regulator.entity(0).throttles << "\n";
}

// One regulation as it runs: the policy and its parameters, the sampling mode and period, the
// scope's accounts and the metric. Built once from a scenario's regulation (or the guard's
// configuration, which the loader reads into the same RegulationSpec) by regulation_setup(),
// which validates it against the policy's traits and converts every period to ns; the sim
// system, the hw point rig and the guard build their regulator from it, and nothing else.
//
// Contract: pure; regulation_setup() throws InputError naming the file and the JSON path. A host
// that cannot run what the setup asks (the hw backend without overflow counters) changes the
// setup's sampling itself and says so (a fallback); the setup it ran is what points.csv reports
// (PointOutcome::sampling).
#pragma once

#include <cstddef>
#include <memory>
#include <string>

#include "backend/backend.h"
#include "policy/policy.h"
#include "policy/rules.h"
#include "regulator/regulator.h"
#include "scenario/scenario.h"

namespace rosguard {

struct RegulationSetup {
  PolicyInfo policy;  // from the run's registry
  // Threshold, reference, regulation period and budgets; monolithic_window_ns is the first RT
  // node's isolation time where the setup was built with baselines (0 otherwise).
  PolicyParams params;
  Sampling sampling = Sampling::Self;
  TimeNs sampling_period_ns = kNsPerMs;
  Scope scope = Scope::Core;
  MetricSpec metric;  // the scenario's; a host that counts other events replaces it
  RegulatedNodes nodes;

  bool regulates() const { return policy.traits.regulates; }
  std::unique_ptr<Policy> make_policy() const;
  RegulatorConfig regulator_config() const;
  std::unique_ptr<Regulator> make_regulator() const;
  // One line for logs: "interval, self sampling every 1000 us, 20 % of 26272 MB/s per 5000 us
  // window, scope core".
  std::string describe() const;
};

// The policy parameters of `r`: threshold, reference, budgets, the regulation period in ns (the
// one place it is converted); the monolithic window 0.
PolicyParams policy_params(const RegulationSpec& r);

// The setup of `r`, validated against its policy's traits in `policies` (check_policy_rules),
// periods in ns. `file` names the document in errors. Throws InputError (unknown policy, a rule
// broken).
RegulationSetup regulation_setup(const RegulationSpec& r, RegulatedNodes nodes,
                                 const PolicyRegistry& policies, const std::string& file);
// The setup of a scenario point. With `baselines` the monolithic window is the first RT node's
// isolation time in them (the policy needs it to size its budget); without, 0.
RegulationSetup regulation_setup(const Scenario& s, const PolicyRegistry& policies,
                                 const Baselines* baselines = nullptr);

}  // namespace rosguard

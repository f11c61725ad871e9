// The scenario rules that depend on what a policy is (its traits), not on its name.
//
// Contract: pure; throws InputError naming the scenario file and the JSON path.
#pragma once

#include "policy/policy.h"
#include "scenario/scenario.h"

namespace rosguard {

// Sampling must be able to see a window's usage before the window closes; a budget sized from
// the RT node's isolation time needs an RT node.
void check_policy_rules(const Scenario& s, const PolicyTraits& traits);
// The traits of s.regulation.policy in `policies` (InputError when unknown), then the rules.
void check_policy(const Scenario& s, const PolicyRegistry& policies);

}  // namespace rosguard

// The scenario rules that depend on what a policy is (its traits), not on its name; the
// policy-dependent defaults; and the policy parameters of a scenario, the same for both backends.
//
// Contract: pure; throws InputError naming the scenario file and the JSON path.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "policy/policy.h"
#include "scenario/scenario.h"

namespace rosguard {

// Sampling must be able to see a window's usage before the window closes; a budget sized from
// the RT node's isolation time needs an RT node; the sampling mode must be one the policy runs
// with; reclaim / sharing and a global budget only where the policy has them.
void check_policy_rules(const Scenario& s, const PolicyTraits& traits);
// The traits of s.regulation.policy in `policies` (InputError when unknown), then the rules.
void check_policy(const Scenario& s, const PolicyRegistry& policies);

// Fills regulation.sampling, regulation.sampling_period_us and regulation.regulation_period_us
// where `regulation` (a scenario's "regulation" object) does not set them: from the built-in
// policy's traits (memguard: overflow, 1000 us; mempol: mmio, 5 us, 1000 us), else the generic
// defaults (self, 1000 us, 5000 us). Returns what a policy's own defaults filled in, as
// "sampling = overflow (memguard's default)", for check's output and the manifest.
std::vector<std::string> apply_policy_defaults(nlohmann::json& regulation);

// The policy parameters of a scenario: threshold, reference, periods, budgets (budget_mbps per
// nRT node becomes one per account: scope core and node have one account per nRT node), the
// per-event and global budgets, reclaim and sharing. `monolithic_window_ns`: the first RT node's
// isolation time (0 without RT nodes).
PolicyParams policy_params(const Scenario& s, TimeNs monolithic_window_ns);

}  // namespace rosguard

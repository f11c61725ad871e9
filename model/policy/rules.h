// The scenario rules that depend on what a policy is (its traits), not on its name; the
// policy-dependent defaults.
//
// Contract: pure; throws InputError naming the scenario file and the JSON path.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "policy/policy.h"
#include "scenario/scenario.h"

namespace rosguard {

// How many nodes a regulation serves: RT nodes (whose activity switches it on) and nRT nodes
// (the regulated entities, in order).
struct RegulatedNodes {
  std::size_t rt = 0;
  std::size_t nrt = 0;
};

// Sampling must be able to see a window's usage before the window closes; a budget sized from
// the RT node's isolation time needs an RT node; the sampling mode must be one the policy runs
// with; reclaim / sharing and a global budget only where the policy has them. `file` names the
// document in errors. (regulation_setup(), regulator/setup.h, applies them with the run's
// registry.)
void check_policy_rules(const RegulationSpec& r, RegulatedNodes nodes, const PolicyTraits& traits,
                        const std::string& file);

// Fills regulation.sampling, regulation.sampling_period_us and regulation.regulation_period_us
// where `regulation` (a scenario's "regulation" object) does not set them: from the built-in
// policy's traits (memguard: overflow, 1000 us; mempol: mmio, 5 us, 1000 us), else the generic
// defaults (self, 1000 us, 5000 us). Returns what a policy's own defaults filled in, as
// "sampling = overflow (memguard's default)", for check's output and the manifest.
std::vector<std::string> apply_policy_defaults(nlohmann::json& regulation);

}  // namespace rosguard

// The subcommands other than `run` (see runner.h). Each returns a process exit code and throws
// InputError (exit 2) or RunError (exit 1) for main() to report.
#pragma once

#include <string>
#include <vector>

#include "backend/backend.h"
#include "loader.h"
#include "policy/policy.h"

namespace rosguard {

// Validates a scenario and prints a summary with the number of points; `list_points` prints
// each point's id and parameters too. `json`: the summary as one JSON object on stdout
// (file, valid, name, backend, backend_built, platform, nodes, sweep, points, repetitions, runs,
// points_checked, sim_seconds_min/max, policy_defaults, warnings; point_list with
// `list_points`); warnings are also on stderr, and an invalid scenario is an InputError as
// without it (nothing on stdout).
int check_scenario(Loader& loader, const BackendRegistry& backends, const std::string& file,
                   const std::optional<std::string>& backend, bool list_points, bool json);

// What is available: "workloads", "platforms", "policies", "backends" or "pmc-sources".
int list_catalogue(const Loader& loader, const PolicyRegistry& policies,
                   const BackendRegistry& backends, const std::string& what);

// Runs the analysis package (`python3 -m analysis <args>`) with the tree's analysis/ on the path.
int run_analysis(const Home& home, const std::vector<std::string>& args);

// Every backend this build has (sim and hw when they are compiled in).
void register_backends(BackendRegistry& registry, const PolicyRegistry& policies);

}  // namespace rosguard

// `rosguard check SCENARIO`: validate a scenario and count its points.
#pragma once

#include <optional>
#include <string>

#include "backend/backend.h"
#include "load/loader.h"

namespace rosguard {

// Validates a scenario and prints a summary with the number of points; `list_points` prints
// each point's id and parameters too. `json`: the summary as one JSON object on stdout
// (file, valid, name, backend, backend_built, platform, nodes, sweep, points, repetitions, runs,
// points_checked, sim_seconds_min/max, policy_defaults, warnings; point_list with
// `list_points`); warnings are also on stderr. Throws InputError for an invalid scenario
// (nothing on stdout).
int check_scenario(Loader& loader, const BackendRegistry& backends, const std::string& file,
                   const std::optional<std::string>& backend, bool list_points, bool json);

}  // namespace rosguard

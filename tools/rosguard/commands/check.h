// `rosguard check SCENARIO`: validate a scenario and count its points.
#pragma once

#include <optional>
#include <string>

#include "backend/backend.h"
#include "load/loader.h"

namespace rosguard {

// Validates a scenario and prints a summary with the number of points; `list_points` prints
// each point's id and parameters too. Throws InputError for an invalid scenario.
int check_scenario(Loader& loader, const BackendRegistry& backends, const std::string& file,
                   const std::optional<std::string>& backend, bool list_points);

}  // namespace rosguard

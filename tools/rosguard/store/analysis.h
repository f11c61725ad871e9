// The analysis package (analysis/, Python) run on results folders: rosguard plot, compare and
// the figures of rosguard calibrate.
#pragma once

#include <string>
#include <vector>

#include "load/loader.h"

namespace rosguard {

// Runs `python3 -m analysis <args>` (ROSGUARD_PYTHON overrides python3) with the tree's
// analysis/ on the path and returns its exit status; throws RunError when it cannot start.
int run_analysis(const Home& home, const std::vector<std::string>& args);

}  // namespace rosguard

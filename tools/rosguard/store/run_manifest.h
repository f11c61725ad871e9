// What manifest.json says about a run before it starts (the results store adds its status,
// counts, shards, fallbacks and facts as the run goes).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "load/loader.h"

namespace rosguard {

// Identity of everything that changes results (not the name, description, or number of
// repetitions): a results folder may be resumed or shared by shards only with the same hash.
std::string scenario_hash(const LoadedScenario& loaded);

// schema_version, tool, command, scenario_file, scenario_hash, scenario (given, expanded and
// the points), workloads (with their reference figures), platform, backend, seed, repetitions,
// host, start_time, warnings; host_platform (the probe, the model's file) for "platform": "host".
// The points are described on `threads` threads.
nlohmann::json describe_run(const LoadedScenario& loaded, const std::string& backend,
                            const std::string& command_line, unsigned threads = 1);

}  // namespace rosguard

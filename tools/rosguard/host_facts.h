// Facts that make results self-describing (recorded in manifest.json): the host, the tool, and
// the wall-clock time.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace rosguard {

// hostname, kernel, machine, cpus_online, cpu_model (when /proc/cpuinfo names one).
nlohmann::json host_facts();

// name, version, git_revision and build_type, as baked in when the build was configured.
nlohmann::json tool_facts();

// The current UTC time as ISO 8601, e.g. 2026-01-31T12:00:00Z.
std::string iso_time_now();

}  // namespace rosguard

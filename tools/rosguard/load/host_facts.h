// Facts that make results self-describing (recorded in manifest.json): the host, the tool, and
// the wall-clock time.
#pragma once

#include <sys/types.h>

#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "calibration/measurements.h"

namespace rosguard {

// hostname, kernel, machine, cpus_online, cpu_model (when /proc/cpuinfo names one).
nlohmann::json host_facts();

// The identity of the machine this process runs on, read without the hw backend, by the rules of
// the hw probe (hw/host_probe.cpp), so that a model calibrated here compares equal: the CPU model
// from /proc/cpuinfo ("model name", else "Hardware", else "unknown (ARCH)"), the usable CPUs
// (online and in this process's affinity mask), the caches of the first usable CPU from sysfs
// (glibc's sysconf where sysfs has none), the kernel as "SYSNAME RELEASE" (uname).
calibration::MachineIdentity this_machine();

// name, version, git_revision and build_type, as baked in when the build was configured.
nlohmann::json tool_facts();

// Who runs this invocation, so that `rosguard status` can tell a shard that still runs from one
// whose process died without finishing (killed, node lost): host (hostname), pid, pid_start
// (process_start_ticks of this process) and, inside a Slurm job, slurm_job ("JOBID_TASK" for
// an array task, else "JOBID", from the SLURM_* environment).
nlohmann::json process_facts();

// Start time of process `pid` in clock ticks after boot (/proc/PID/stat, field 22): with the pid
// it names one process, also after the pid is reused. nullopt when there is no such process.
std::optional<unsigned long long> process_start_ticks(pid_t pid);

// The current UTC time as ISO 8601, e.g. 2026-01-31T12:00:00Z.
std::string iso_time_now();

}  // namespace rosguard

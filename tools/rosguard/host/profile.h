// `rosguard profile`: runs a program under valgrind's lackey (--trace-mem=yes), streams the
// trace through a pipe into the cache model of model/profile/ and writes a sim workload profile
// (scenarios/schema/workload.schema.json). Called from main() only; throws InputError for bad
// arguments (exit 2) and RunError when valgrind is missing or the program fails (exit 1).
#pragma once

#include <cstdint>
#include <iosfwd>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "load/schema.h"
#include "profile/profiler.h"

namespace rosguard {

struct ProfileOptions {
  std::vector<std::string> command;  // program and its arguments
  std::string out;                   // the workload JSON to write
  std::string name;                  // default: the program's file name
  std::string slices_csv;            // per-slice counts, when not empty
  std::uint64_t slice_instructions = 2'000'000;
  std::uint64_t max_instructions = 0;   // 0: the whole run
  std::uint64_t skip_instructions = 0;  // run through the caches uncounted first
  std::string caches_kb = "64,256,2048";
  std::string ways = "4,8,16";
  bool quiet = false;
};

// The profiler's configuration from the options (InputError on a bad --caches / --ways).
profile::ProfilerConfig profile_config(const ProfileOptions& options);

struct ProfileRun {
  std::string program;  // resolved path
  std::string valgrind_version;
  bool bounded = false;  // stopped at max_instructions
  double wall_seconds = 0;
  // CPU time (user + system) of valgrind (with the program) and of this process.
  double tracer_cpu_seconds = 0, profiler_cpu_seconds = 0;
  std::string date_utc;
};

// Runs the program under lackey and feeds `profiler`; progress lines go to `progress` (nullptr:
// none). Throws RunError when valgrind is missing or the program exits non-zero.
ProfileRun trace_program(const ProfileOptions& options, profile::Profiler& profiler,
                         std::ostream* progress);

// The workload document (valid against workload.schema.json).
nlohmann::json workload_document(const ProfileOptions& options, const profile::Profiler& profiler,
                                 const ProfileRun& run);

// The whole command: trace, build, validate, write atomically; a summary on stderr.
int profile_command(const ProfileOptions& options, const SchemaSet& schemas);

}  // namespace rosguard

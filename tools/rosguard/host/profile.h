// `rosguard profile`: runs a program under valgrind's lackey (--trace-mem=yes), streaming the
// trace through a pipe into the cache model of model/profile/, or under valgrind's callgrind
// once per cache capacity (model/profile/callgrind.h, about 20x faster), and writes a workload
// (scenarios/schema/workload.schema.json): the sim profile, and the program as the hw command.
// Called from main() only; throws InputError for bad arguments (exit 2) and RunError when valgrind
// is missing or the program fails (exit 1).
#pragma once

#include <cstdint>
#include <filesystem>
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
  std::string tracer = "lackey";  // or "callgrind"
  unsigned jobs = 0;              // callgrind runs at a time; 0: one per CPU
  // The fit of base_ipc on `platform` ("host", a file or a name under platforms_dir): to
  // fit_ipc when > 0, or to the IPC of the program run natively `repeat` times (measure_ipc).
  std::string platform = "orin-agx";
  std::filesystem::path platforms_dir;
  double fit_ipc = 0;
  bool measure_ipc = false;
  int repeat = 3;
  bool caches_from_platform = false;  // --platform given, --caches not: L1,L2,L3 from it
  bool quiet = false;
};

// What a tracer measured, for the workload document.
struct ProfileData {
  profile::ProfilerConfig config;
  std::vector<std::uint64_t> capacities_kb;  // of the MRC, ascending, the L3's included
  std::vector<profile::SliceCounts> slices;
  std::uint64_t instructions = 0;
  std::uint64_t footprint_lines = 0;
  bool mlp_measured = true;  // callgrind's counts show no overlap of refills
  std::string method;        // the tracer's options, for the workload's source
  std::string cache_model;   // how the counts were simulated, ditto
};
ProfileData profile_data(const profile::Profiler& profiler);

// The profiler's configuration from the options (InputError on a bad --caches / --ways).
profile::ProfilerConfig profile_config(const ProfileOptions& options);

struct ProfileRun {
  std::string program;  // resolved path
  std::string valgrind_version;
  bool bounded = false;  // stopped at max_instructions
  double wall_seconds = 0;
  // CPU time (user + system) of valgrind (with the program) and of this process.
  double tracer_cpu_seconds = 0, profiler_cpu_seconds = 0;
  int tracer_runs = 1;  // the program's runs under valgrind (callgrind: one per capacity)
  std::string date_utc;
};

// Runs the program under lackey and feeds `profiler`; progress lines go to `progress` (nullptr:
// none). Throws RunError when valgrind is missing or the program exits non-zero.
ProfileRun trace_program(const ProfileOptions& options, profile::Profiler& profiler,
                         std::ostream* progress);

// Runs the program under callgrind, once per capacity (options.jobs at a time), into `data`.
// The same errors as trace_program.
ProfileRun callgrind_program(const ProfileOptions& options, ProfileData& data,
                             std::ostream* progress);

// The workload document (valid against workload.schema.json).
nlohmann::json workload_document(const ProfileOptions& options, const ProfileData& data,
                                 const ProfileRun& run);

// The whole command: trace, build, validate, write atomically; a summary on stderr.
int profile_command(const ProfileOptions& options, const SchemaSet& schemas);

}  // namespace rosguard

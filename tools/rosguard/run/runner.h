// `rosguard run`: the named lifecycle of a run, the same for every backend.
//   load + validate (nothing written on error) -> prepare the results folder (resume, shards)
//   -> isolation baselines -> unregulated co-runs (once per distinct co-run of the nodes with
//   policy none, unregulated.h) -> every point x repetition -> sort rows, finish the manifest.
// Tasks of a process_per_task backend run in forked workers (--jobs at a time); others run one
// at a time in this process. SIGINT / SIGTERM stop dispatching, let the backend return its
// nodes to nominal, keep complete rows, and give exit code 130 / 143.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "backend/backend.h"
#include "load/loader.h"

namespace rosguard {

struct RunOptions {
  std::string scenario_file;
  std::optional<std::string> backend;  // overrides the scenario's "backend"
  std::filesystem::path out;           // empty: results/<scenario name>
  int jobs = 0;                        // 0: one per online CPU
  int shard_index = 0;
  int shard_count = 1;
  bool resume = false;
  bool overwrite = false;
  bool trace = false;
  bool quiet = false;
  // Measure the unregulated co-run of every regulated point, once per co-run key
  // (unregulated.h); off: rosguard run --no-unregulated.
  bool unregulated = true;
  std::string command_line;  // recorded in the manifest
  // The process ends after the run (the command line): a finished run leaves its loaded points
  // to the process's end instead of freeing them (70 ms for 10,000 points on the development
  // VM, a step no worker could share).
  bool process_ends = false;
};

// Loads the scenario and validates every point against its backend, as run_scenario does before
// it writes anything: InputError (exit 2); RunError when the backend is not built in.
LoadedScenario load_for_run(const RunOptions& options, Loader& loader,
                            const BackendRegistry& backends);

// The results folder of a run: --out, else results/<scenario name>.
std::filesystem::path results_folder(const RunOptions& options, const LoadedScenario& loaded);

// Returns the process exit code (0 ok, 1 runtime failure, 130 / 143 interrupted). Throws
// InputError (exit 2) before anything is written.
int run_scenario(const RunOptions& options, Loader& loader, const BackendRegistry& backends);

}  // namespace rosguard

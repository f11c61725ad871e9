// `rosguard tune`: the regulation setting that keeps every RT node within a slowdown bound and
// gives the nRT nodes the most progress, found in sim.
//
// The space: the scenario's regulation sweep keys (regulation.policy, .sampling, the periods,
// any other regulation.* key) bound it; a scenario that sweeps none of them but the threshold
// gets the default space (every registered policy whose traits say it throttles x sampling self
// and external x three sampling / regulation period pairs). The threshold ladder is the swept
// regulation.threshold_pct list, else the default ladder (1 .. 100 %). The other sweep keys
// (workloads, cores, ...) are cases the setting must satisfy together.
//
// The search: for each configuration (everything but the threshold) the best threshold is the
// largest one that meets the bound when RT slowdown grows and nRT slowdown falls with the
// threshold, so it is bisected over the ladder, every configuration's next probe in one batch
// (one `rosguard run` of a generated scenario, --jobs workers). Every probe is checked against
// that monotonicity; a configuration whose probes contradict it is scanned instead (a note says
// so). The unregulated co-run (policy none) is simulated once per case.
//
// Results folder (default results/<scenario name>/tune): probes/step-NN{.json,/} (each batch's
// scenario and its results folder), points.csv / samples.csv / manifest.json of every simulated
// point (standard columns: `rosguard plot DIR` draws them), tune.json, and with --confirm hw
// confirm-hw/ (the winner and the unregulated co-run measured on this machine).
#pragma once

#include <filesystem>
#include <string>

#include "backend/backend.h"
#include "loader.h"
#include "policy/policy.h"

namespace rosguard {

struct TuneOptions {
  std::string scenario_file;
  double rt_slowdown_max = 0.0;              // X: every RT node's slowdown must be <= X (>= 1)
  std::string objective = "nrt-throughput";  // the only one: lowest mean nRT slowdown
  std::string confirm;                       // "" or "hw"
  std::filesystem::path out;                 // empty: results/<scenario name>/tune
  int jobs = 0;                              // sim workers per batch; 0: one per online CPU
  bool quiet = false;
  bool overwrite = false;  // replace an earlier tune in --out
  std::string command_line;
};

// Runs the search and prints the best setting, the runner-up and the unregulated co-run.
// Returns 0 when a setting meets the bound, 1 when none does (the closest is printed and
// written), 130 / 143 when interrupted. Throws InputError (exit 2) for a scenario that cannot be
// tuned (no RT or no nRT node, X < 1, an hw scenario without --confirm hw, a sweep key that ties
// regulation and other paths, an empty space) and RunError when a batch fails.
int tune_scenario(const TuneOptions& options, Loader& loader, const BackendRegistry& backends,
                  const PolicyRegistry& policies);

}  // namespace rosguard

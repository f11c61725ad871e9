// `rosguard tune`: the regulation setting that keeps every RT node within a slowdown bound and
// gives the nRT nodes the most progress, found in sim.
//
// The space: the scenario's regulation sweep keys (regulation.policy, .sampling, the periods,
// any other regulation.* key, joined or not) bound it, a path no key sets keeping the
// scenario's value, else the policy's default; a scenario that sweeps none of them but the
// threshold gets the default space (every registered policy whose traits say it throttles x
// sampling self and external x three sampling / regulation period pairs). The threshold ladder is
// the swept regulation.threshold_pct list, else the default ladder (1 .. 100 %). The other sweep
// keys (workloads, cores, ...) are cases the setting must satisfy together.
//
// The search: for each configuration (everything but the threshold) the best threshold is the
// largest one that meets the bound when RT slowdown grows and nRT slowdown falls with the
// threshold, so it is bisected over the ladder, every configuration's next probe in one batch
// (one `rosguard run` of a generated scenario, --jobs workers). Every probe is checked against
// that monotonicity; a configuration whose probes contradict it is scanned instead (a note says
// so). The unregulated co-run (policy none, the other regulation settings at their defaults) is
// a batch of its own, once per case.
//
// Results folder (default results/<scenario name>/tune): probes/unregulated{.json,/} and
// probes/step-NN{.json,/} (each batch's scenario and its results folder), points.csv / samples.csv
// / manifest.json of every simulated point (standard columns: `rosguard plot DIR` draws them),
// tune.json, and with --confirm hw confirm-hw/ and confirm-hw-unregulated/ (the winner and the
// unregulated co-run measured on this machine).
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "backend/backend.h"
#include "load/loader.h"
#include "policy/policy.h"

namespace rosguard {

// One configuration's search over a threshold ladder of `rungs` ascending rungs.
//
// Contract: call next() for the rungs to simulate in the next batch, record() each one's
// result, then update(); repeat until next() returns nothing. While the probes agree with
// monotonicity (RT slowdown does not fall as the threshold rises; among the probes that meet
// the bound, nRT slowdown does not rise; within max(0.005, 1 % of the larger value)) it
// bisects for the highest rung that meets the bound and then probes the rung below it once;
// after a contradiction it scans: every rung not yet probed, in one batch. pick() is then the
// probed rung that meets the bound with the lowest nRT slowdown (ties: the lower RT slowdown).
class ThresholdSearch {
 public:
  struct Probe {
    double rt = 0.0;   // worst RT slowdown (NaN: not measured, never meets the bound)
    double nrt = 0.0;  // the objective: mean nRT slowdown
    bool feasible = false;
  };

  explicit ThresholdSearch(int rungs);

  std::vector<int> next();
  void record(int rung, const Probe& probe);
  // Moves the bounds and checks monotonicity over every probe so far. Returns the
  // contradiction found ("RT slowdown 1.2 at rung 3 but 1.1 at rung 5"; `rung_text` names a
  // rung), after which the search scans; "" otherwise.
  std::string update(const std::function<std::string(int)>& rung_text);

  bool scanning() const { return mode_ == Mode::Scan || scanned_; }
  bool scanned() const { return scanned_; }  // a contradiction was found
  const std::map<int, Probe>& probes() const { return probes_; }
  std::optional<int> pick() const;

 private:
  enum class Mode { Bisect, Scan, Done };
  int rungs_;
  int lo_ = -1;  // highest rung known to meet the bound (-1: none)
  int hi_;       // lowest rung known not to (rungs_: none)
  Mode mode_ = Mode::Bisect;
  bool verified_ = false;
  bool scanned_ = false;
  std::map<int, Probe> probes_;
};

struct TuneOptions {
  std::string scenario_file;
  double rt_slowdown_max = 0.0;              // X: every RT node's slowdown must be <= X (>= 1)
  std::string objective = "nrt-throughput";  // the only one: lowest mean nRT slowdown
  std::string confirm;                       // "" or "hw"
  std::vector<double> thresholds;            // the ladder (%, in (0, 100]); empty: the sweep's
  std::filesystem::path out;                 // empty: results/<scenario name>/tune
  int jobs = 0;                              // sim workers per batch; 0: one per online CPU
  bool quiet = false;
  bool overwrite = false;  // replace an earlier tune in --out
  // "guard": only settings `rosguard guard` runs (guard_config.h); each left out is noted.
  std::string deployable;
  std::filesystem::path emit_guard;  // write the best as a guard configuration (implies guard)
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

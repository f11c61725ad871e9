// The unregulated co-run of a run's points: the same nodes on the same cores with regulation
// off (policy none), measured once per distinct co-run (not once per threshold or setting) so
// that every slowdown can be read against what regulation protects the RT node from.
//
// Contract: a co-run key (corun_key) covers everything that can change an unregulated co-run
// (backend, platform, nodes with their workloads and cores, seed, sim / hw settings) and nothing
// of the regulation: every point that differs only in its regulation shares one co-run. The
// runner measures each key the backend's baseline_repetitions() times (sim: once, hw: as the
// isolation baselines, interleaved with the repetition rounds in the same way), after the
// isolation baselines it needs. Measurements live in DIR/unregulated.json:
//   {KEY: {"rt_time_us": [median per RT node], "nrt_time_us": [median per nRT node],
//          "runs": [{"rep", "rt_time_us": [...], "nrt_time_us": [...]}, ...]}}
// (NaN written null), merged under DIR/.lock like baselines.json, so that resumed runs and other
// shards take what is there and do not measure it again. The points.csv columns
// rt_unregulated_time_us / _slowdown and nrt_unregulated_time_us / _slowdown, and those of every
// further node (rt1_unregulated_time_us, nrt2_unregulated_slowdown, ...), come from it (a
// point whose policy is none carries its own times; with hw.adjacent_baselines a co-run has
// baselines of its own, measured right before each of its runs, and the slowdown is the median
// of the runs' ratios). `rosguard run --no-unregulated` skips the
// co-runs (the columns stay empty unless the folder holds them already).
#pragma once

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "backend/backend.h"
#include "scenario/scenario.h"

namespace rosguard {

// One measurement of an unregulated co-run: each node's time (RtOutcome / NrtOutcome time_us).
struct CorunResult {
  std::vector<double> rt_time_us;
  std::vector<double> nrt_time_us;
};

class UnregulatedCoruns {
 public:
  // True when `point` has an unregulated co-run to measure: it has RT and nRT nodes and a
  // policy other than none (a policy-none point is its own unregulated co-run).
  // An RT node signalled by a topic (another program's jobs, `"signal": "topic"`) has no
  // co-run: its jobs cannot be run twice (the run says so in the manifest fact).
  static bool needed(const Scenario& point);
  static bool signalled_elsewhere(const Scenario& point);
  // The co-run's identity (see the contract above), e.g. "corun/mser+bandwidth_read/1a2b3c4d".
  static std::string key(const Scenario& point);
  // `point` with its regulation off: policy none, the other regulation settings at their
  // defaults (the metric and reference bandwidth kept); everything else as it is.
  static Scenario scenario_of(const Scenario& point);

  void put(const std::string& key, CorunResult result, int rep);
  bool has(const std::string& key, int rep) const;
  // Node by node median of the measurements of `key` (NaN ignored); nullopt when none.
  std::optional<CorunResult> median(const std::string& key) const;
  const std::map<std::string, std::map<int, CorunResult>>& all() const { return by_key_; }
  std::size_t measurements() const;  // over every key

  // The document DIR/unregulated.json holds, and back (throws json::exception for another).
  nlohmann::json to_json() const;
  static UnregulatedCoruns from_json(const nlohmann::json& doc);

  // DIR/unregulated.json; empty when the file is missing. Throws RunError for a file of
  // another shape (naming it).
  static UnregulatedCoruns read(const std::filesystem::path& dir);
  // Merges these measurements into DIR/unregulated.json under DIR/.lock: measurements the file
  // already holds (another shard's of the same index) are kept. Call it while holding no lock
  // on DIR/.lock.
  void save(const std::filesystem::path& dir) const;

 private:
  std::map<std::string, std::map<int, CorunResult>> by_key_;
};

// The points.csv line `line` (no newline; columns `header`; a point of scenario `s`, whose
// co-run key is `corun_key`: UnregulatedCoruns::key(s), read only when the point needs a
// co-run) with its unregulated cells set: from the co-run's median over the isolation
// baselines' median when the point needs a co-run and it was measured, from the row's own time
// and slowdown of each node when the policy is none, left as they are otherwise; for every node
// the header has columns for. A header without those columns leaves the line unchanged.
std::string fill_unregulated_cells(const std::vector<std::string>& header, const std::string& line,
                                   const Scenario& s, const std::string& corun_key,
                                   const UnregulatedCoruns& coruns, const Baselines& baselines);

}  // namespace rosguard

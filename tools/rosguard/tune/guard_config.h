// What `rosguard guard` can deploy of a tuned regulation setting, and the guard configuration
// that deploys it (`rosguard tune --deployable guard`, `--emit-guard FILE`).
//
// Contract: pure (no files); the configuration returned passes `rosguard guard FILE --check`
// for every setting guard_refusal() accepts, on the scenario's nodes (one nRT node per core).
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "scenario/scenario.h"

namespace rosguard {

// Why `rosguard guard` cannot run a setting: `paths` are the setting's regulation paths
// ("regulation.policy", "regulation.sampling", ...), `values` their values (null: unset). Empty
// when it can.
std::optional<std::string> guard_refusal(const std::vector<std::string>& paths,
                                         const nlohmann::json& values);

// Why the guard cannot regulate the scenario's nodes as they are placed (two nRT nodes on one
// core, the controller on an nRT core); empty when it can.
std::optional<std::string> guard_placement_refusal(const NodesSpec& nodes);

struct TunedSetting {
  std::vector<std::string> paths;  // as guard_refusal()
  nlohmann::json values;
  double threshold_pct = 0.0;
  double reference_mbps = 0.0;                  // the run's (the platform's or the scenario's)
  std::optional<std::int64_t> rt_isolation_us;  // monolithic: the first RT node's time alone
  std::string description;
};

// The guard configuration deploying `t` on `nodes`, named `name` (made a valid guard name).
// Keys the setting leaves unset take the guard's defaults; `regulation` is the scenario's
// resolved regulation (its scope, reclaim, sharing, global cap where the setting sets none).
nlohmann::json guard_config(const std::string& name, const NodesSpec& nodes,
                            const nlohmann::json& regulation, const TunedSetting& t);

}  // namespace rosguard

// Sweep expansion over dotted paths ("regulation.threshold_pct", "nodes.rt[0].workload").
//
// Contract: pure functions on JSON documents. Points are the cartesian product of the sweep
// lists; the first key written varies slowest. A key joining paths with '+' makes them co-vary:
// its values are tuples, one element per path. A point's id depends only on its parameter
// values (not on the backend, platform or order), so resumed, sharded and cross-backend result
// folders can be matched point by point.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/error.h"

namespace rosguard {

struct SweepParam {
  std::string path;  // dotted, as written in the sweep
  nlohmann::json value;
  std::size_t value_index = 0;  // position of the value (or tuple) in the sweep list
  std::string key;              // the sweep key it comes from (several paths joined by '+')
  std::size_t component = 0;    // position of `path` in that key
};

struct SweepPoint {
  std::size_t index = 0;           // position in the stable order
  std::string id;                  // stable id of the parameters, e.g. "p3fa0c2e19b"
  std::vector<SweepParam> params;  // in sweep key order
  nlohmann::json document;         // the base document with the values substituted, no sweep
                                   // (the loader drops it once the Scenario is built)
};

// One segment of a dotted path: an object key, then zero or more array indexes.
struct PathSegment {
  std::string key;
  std::vector<std::size_t> indexes;
};

// The paths of a sweep key: one, or several joined by '+' that co-vary (their values are
// tuples: "regulation.sampling_period_us+regulation.regulation_period_us": [[500, 2500], ...]).
std::vector<std::string> split_sweep_key(const std::string& key);

// Parses "nodes.rt[0].workload". Throws InputError (no file, no JSON path: the caller knows
// where the path was written) on a malformed path.
std::vector<PathSegment> parse_sweep_path(const std::string& path);

// JSON pointer ("/nodes/rt/0/workload") of a dotted path.
std::string to_json_pointer(const std::vector<PathSegment>& path);

// Writes `value` at `path` in `doc`. Missing object keys are created; arrays must already hold
// the index. Throws InputError (no file, no JSON path) saying which segment does not exist.
void set_at_path(nlohmann::json& doc, const std::vector<PathSegment>& path,
                 const nlohmann::json& value);

// Stable id of a parameter assignment ("p" + 10 hex digits of FNV-1a over the canonical form).
std::string point_id(const std::vector<SweepParam>& params);

// A sweep value that cannot be written at its path in one point: an earlier sweep key reshaped
// the document (e.g. "nodes.rt": [[]] empties the array that "nodes.rt[0].core" indexes).
// Its JSON path is the sweep key ("/sweep/nodes.rt[0].core"); it has no file.
class SweepPathError : public InputError {
 public:
  SweepPathError(std::string key, const std::string& why)
      : InputError("", "/sweep" + to_json_pointer({{key, {}}}),
                   "this path does not exist in every point: " + why +
                       " (another sweep key changes what it points into)"),
        key_(std::move(key)) {}
  const std::string& key() const { return key_; }  // the sweep key whose value did not fit

 private:
  std::string key_;
};

// The points of a sweep, counted without building them; point(i) builds one on demand.
// `doc` holds a "sweep" object (possibly empty); `key_order` is the order its keys were written
// in (JSON objects here are sorted, so the loader passes it). The plan refers to `doc`, which
// must outlive it. The constructor throws InputError (no file) at the offending key (a malformed
// path or value list) or at "/sweep" (a product of list sizes beyond 2^64 - 1), and
// ContractError when `key_order` does not list the sweep's keys.
class SweepPlan {
 public:
  SweepPlan(const nlohmann::json& doc, const std::vector<std::string>& key_order);

  std::uint64_t count() const { return count_; }
  // Size of each key's value list, in key order.
  std::vector<std::uint64_t> sizes() const;
  // Point `index` (< count()); throws SweepPathError when a value cannot be written.
  SweepPoint point(std::uint64_t index) const;

 private:
  struct Key {
    std::string key;
    std::vector<std::string> names;
    std::vector<std::vector<PathSegment>> paths;
    const nlohmann::json* values;
  };
  nlohmann::json base_;
  std::vector<Key> keys_;
  std::uint64_t count_ = 1;
};

// Every point of the sweep, in order (SweepPlan::point for each index).
std::vector<SweepPoint> expand_sweep(const nlohmann::json& doc,
                                     const std::vector<std::string>& key_order);

}  // namespace rosguard

// The dictionary of result columns: for every column of points.csv and every sample kind of
// samples.csv, its unit and meaning. One source for `DIR/columns.json` (written into every
// results folder), `rosguard list columns` and the results section of docs/results.md.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace rosguard {

struct ColumnInfo {
  std::string name;     // as in the file; a pattern ("rt<i>_time_us") in the full dictionary
  std::string unit;     // "us", "MiB/s", "ratio", "count", "IPC", "%", "text", "" (no unit)
  std::string meaning;  // one sentence
};

// Every points.csv column, per-node and sweep-parameter columns as patterns.
const std::vector<ColumnInfo>& point_column_dictionary();
// Every samples.csv kind (the unit is that of value_us).
const std::vector<ColumnInfo>& sample_kind_dictionary();

// The entry of one concrete points.csv column ("rt2_slowdown", "param:regulation.x"), or
// nullopt for a column the dictionary does not know.
std::optional<ColumnInfo> describe_point_column(const std::string& name);

}  // namespace rosguard

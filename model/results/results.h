// Rows of points.csv and samples.csv (docs/design.md, results), built from a point's outcome.
//
// Contract: pure formatting. The header of points.csv is fixed for a run: computed once from
// every point (node counts and sweep keys), then every row has exactly its columns. Numbers
// are written with fixed decimals, so identical outcomes give byte-identical rows.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "backend/backend.h"
#include "results/precision.h"
#include "scenario/scenario.h"
#include "scenario/sweep.h"

namespace rosguard {

// The columns docs/design.md fixes, in order; other columns follow them.
const std::vector<std::string>& fixed_point_columns();

// Header of points.csv for a run: the fixed columns, then platform / counts, the first nodes'
// names and cores (rt_name, nrt_core, ...) and the unregulated co-run (rt_ /
// nrt_unregulated_time_us, _slowdown), then per-node columns for the second and later RT / nRT
// nodes (their unregulated co-run last: rt1_unregulated_time_us, ...), then one "param:<path>"
// column per swept path.
std::vector<std::string> points_header(std::size_t max_rt, std::size_t max_nrt,
                                       const std::vector<std::string>& sweep_paths);

// One CSV line (with '\n') of points.csv for `header`.
std::string points_row(const std::vector<std::string>& header, const SweepPoint& point,
                       const Scenario& scenario, int rep, const PointOutcome& outcome,
                       const Baselines& baselines);

// The row `line` of points.csv (for `header`, of a point of scenario `s`) with the cells that come
// from the isolation baselines (isolation time, ipc, mbps, count, spread, slowdown) recomputed
// from `baselines`; nullopt when they are unchanged (the row stays byte for byte) or when a
// baseline is missing. A run writes a row with the baselines measured so far and refreshes it
// once the rest are in (hw: the median of every measurement).
std::optional<std::string> refresh_isolation_cells(const std::vector<std::string>& header,
                                                   const std::string& line, const Scenario& s,
                                                   const Baselines& baselines);

// The co-run times of a points.csv row (`cells` for `header`, of a point of scenario `s`): its
// RT nodes' time_us, then its nRT nodes', in scenario order; NaN for an empty or odd cell.
std::vector<double> row_node_times(const std::vector<std::string>& header,
                                   const std::vector<std::string>& cells, const Scenario& s);

// The rows of one point (`lines`, each a points.csv row for `header` without its newline, of a
// point of scenario `s`) with their slowdown precision cells (rt_slowdown_ci95_pct,
// nrt_slowdown_ci95_pct, rt<i>_ / nrt<i>_slowdown_ci95_pct) set from all of them together
// (slowdown_cis over the rows' repetitions, with `pairing`): every row of a point carries the
// point's CIs; empty where a node's baseline is missing or fewer than two rows have its time.
std::vector<std::string> fill_ci_cells(const std::vector<std::string>& header,
                                       const std::vector<std::string>& lines, const Scenario& s,
                                       const Baselines& baselines, const RoundPairing& pairing);

inline constexpr const char* kSamplesHeader = "point,rep,kind,value_us";

// The samples.csv lines of one point and repetition: the outcome's samples, then each RT node's
// response times (kind rt_job for the first RT node, rt1_job, ... for the others).
std::string samples_rows(const std::string& point_id, int rep, const PointOutcome& outcome);

// Median (mean of the two middle values for an even count) and maximum; NaN when empty.
double median(std::vector<double> values);
// The same over the finite values only (NaN and infinities left out); NaN when none is.
double finite_median(std::vector<double> values);
double maximum(const std::vector<double>& values);
// Percentile q (0..100), linear between the closest ranks (numpy's default); NaN when empty.
double percentile(std::vector<double> values, double q);
// Sample standard deviation over the mean; NaN for fewer than two values or a mean <= 0.
double coefficient_of_variation(const std::vector<double>& values);

// RFC 4180 quoting when needed.
std::string csv_escape(const std::string& field);
// Splits one CSV line (no trailing newline), honouring quotes.
std::vector<std::string> csv_split(const std::string& line);

}  // namespace rosguard

#include "results/results.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <optional>
#include <string>

#include "results/precision.h"

namespace rosguard {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string fixed(double v, int decimals) {
  if (std::isnan(v) || std::isinf(v)) return "";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  std::string s = buf;
  if (s == "-0" || s.find_first_not_of("-0.") == std::string::npos) s = s.substr(s[0] == '-');
  return s;
}

std::string us(double v) {
  return fixed(v, 3);
}
std::string ratio(double v) {
  return fixed(v, 6);
}
std::string mbps(double v) {
  return fixed(v, 3);
}

std::string compact(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

// The cells of node `prefix` ("rt_", "nrt1_", ...) that come from its isolation baseline, for a
// co-run time `t` of repetition `rep`; `first`: the node whose ipc / mbps have fixed columns.
// The isolation time is the median of the baseline's measurements, or with adjacent baselines
// (hw.adjacent_baselines) the measurement taken right before this repetition's co-run.
void isolation_cells(std::map<std::string, std::string>& cell, const std::string& prefix,
                     bool first, const BaselineRuns& runs, double t, const Scenario& s, int rep) {
  const IsolationResult iso = runs.median();
  const double time_us =
      s.hw.adjacent_baselines ? round_baseline_us(runs, rep, adjacent_pairing()) : iso.time_us;
  cell[prefix + "isolation_us"] = us(time_us);
  cell[prefix + "slowdown"] = ratio(t / time_us);
  cell[prefix + "isolation_n"] = std::to_string(runs.count());
  cell[prefix + "isolation_cv"] = ratio(runs.time_cv());
  if (first) {
    cell[prefix + "isolation_ipc"] = ratio(iso.ipc);
    cell[prefix + "isolation_mbps"] = mbps(iso.mbps);
  }
}

std::string prefix_of(const char* kind, std::size_t i) {
  return i == 0 ? std::string(kind) + "_" : kind + std::to_string(i) + "_";
}

std::string rt_job_kind(std::size_t i) {
  return i == 0 ? "rt_job" : "rt" + std::to_string(i) + "_job";
}

std::string join_cells(const std::vector<std::string>& header,
                       const std::map<std::string, std::string>& cell) {
  std::string line;
  for (std::size_t c = 0; c < header.size(); ++c) {
    if (c) line += ',';
    auto it = cell.find(header[c]);
    if (it != cell.end()) line += csv_escape(it->second);
  }
  return line;
}

std::vector<double> values_of(const PointOutcome& o, const std::string& kind) {
  std::vector<double> v;
  for (const auto& s : o.samples)
    if (s.kind == kind) v.push_back(s.value_us);
  return v;
}

}  // namespace

double median(std::vector<double> v) {
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double finite_median(std::vector<double> v) {
  std::erase_if(v, [](double x) { return !std::isfinite(x); });
  return median(std::move(v));
}

double coefficient_of_variation(const std::vector<double>& v) {
  if (v.size() < 2) return kNaN;
  double mean = 0.0;
  for (double x : v)
    mean += x;
  mean /= static_cast<double>(v.size());
  double ss = 0.0;
  for (double x : v)
    ss += (x - mean) * (x - mean);
  return mean > 0.0 ? std::sqrt(ss / static_cast<double>(v.size() - 1)) / mean : kNaN;
}

double maximum(const std::vector<double>& v) {
  return v.empty() ? kNaN : *std::max_element(v.begin(), v.end());
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const double pos = q / 100.0 * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(pos);
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

const std::vector<std::string>& fixed_point_columns() {
  static const std::vector<std::string> columns = {"point",
                                                   "rep",
                                                   "backend",
                                                   "rt_workload",
                                                   "nrt_workload",
                                                   "policy",
                                                   "sampling",
                                                   "scope",
                                                   "threshold_pct",
                                                   "sampling_period_us",
                                                   "regulation_period_us",
                                                   "rt_time_us",
                                                   "rt_isolation_us",
                                                   "rt_slowdown",
                                                   "nrt_time_us",
                                                   "nrt_isolation_us",
                                                   "nrt_slowdown",
                                                   "nrt_bandwidth_mbps",
                                                   "throttle_count",
                                                   "throttled_us",
                                                   "activation_delay_p50_us",
                                                   "activation_delay_max_us",
                                                   "pmc_callback_p50_us",
                                                   "rt_isolation_ipc",
                                                   "rt_isolation_mbps",
                                                   "nrt_isolation_ipc",
                                                   "nrt_isolation_mbps"};
  return columns;
}

std::vector<std::string> points_header(std::size_t max_rt, std::size_t max_nrt,
                                       const std::vector<std::string>& sweep_paths) {
  std::vector<std::string> h = fixed_point_columns();
  for (const char* c :
       {"platform", "nrt_mode", "rt_jobs", "nrt_runs", "reference_mbps", "sampling_overhead_p50_us",
        "pmc_callback_max_us", "rt_isolation_n", "rt_isolation_cv", "nrt_isolation_n",
        "nrt_isolation_cv", "rt_response_p99_us", "rt_response_max_us", "rt_deadline_misses",
        "signal_latency_p50_us", "signal_to_thr_p50_us"})
    h.emplace_back(c);
  // Which nodes the first RT / nRT columns belong to, and the first nRT node's throttling under
  // its node prefix (throttle_count / throttled_us above are the same values, by their fixed
  // names).
  for (const char* c :
       {"rt_name", "rt_core", "nrt_name", "nrt_core", "nrt_throttle_count", "nrt_throttled_us"})
    h.emplace_back(c);
  // The point's unregulated co-run (filled by the runner: tools/rosguard/run/unregulated.h).
  for (const char* c : {"rt_unregulated_time_us", "rt_unregulated_slowdown",
                        "nrt_unregulated_time_us", "nrt_unregulated_slowdown"})
    h.emplace_back(c);
  // The precision of the point's slowdowns over its repetitions (fill_ci_cells).
  for (const char* c : {"rt_slowdown_ci95_pct", "nrt_slowdown_ci95_pct"})
    h.emplace_back(c);
  for (std::size_t i = 1; i < max_rt; ++i)
    for (const char* c :
         {"workload", "name", "core", "time_us", "isolation_us", "slowdown", "isolation_n",
          "isolation_cv", "response_p99_us", "response_max_us", "deadline_misses",
          "slowdown_ci95_pct", "unregulated_time_us", "unregulated_slowdown"})
      h.push_back("rt" + std::to_string(i) + "_" + c);
  for (std::size_t i = 1; i < max_nrt; ++i)
    for (const char* c :
         {"workload", "name", "core", "time_us", "isolation_us", "slowdown", "isolation_n",
          "isolation_cv", "bandwidth_mbps", "throttle_count", "throttled_us", "slowdown_ci95_pct",
          "unregulated_time_us", "unregulated_slowdown"})
      h.push_back("nrt" + std::to_string(i) + "_" + c);
  for (const auto& p : sweep_paths)
    h.push_back("param:" + p);
  return h;
}

std::string points_row(const std::vector<std::string>& header, const SweepPoint& point,
                       const Scenario& s, int rep, const PointOutcome& o, const Baselines& b) {
  std::map<std::string, std::string> cell;
  const RegulationSpec& r = s.regulation;
  cell["point"] = point.id;
  cell["rep"] = std::to_string(rep);
  cell["backend"] = s.backend;
  cell["policy"] = r.policy;
  // The sampling it ran with (a backend may run another than the scenario's: a fallback).
  cell["sampling"] = std::string(to_string(o.sampling ? o.sampling->mode : r.sampling));
  cell["scope"] = std::string(to_string(r.scope));
  cell["threshold_pct"] = compact(r.threshold_pct);
  cell["sampling_period_us"] = o.sampling
                                   ? compact(static_cast<double>(o.sampling->period_ns) / 1e3)
                                   : std::to_string(r.sampling_period_us);
  cell["regulation_period_us"] = std::to_string(r.regulation_period_us);
  cell["reference_mbps"] = mbps(r.reference_mbps);
  cell["platform"] = s.platform.name;

  const auto rt_cells = [&](const std::string& prefix, std::size_t i, bool first) {
    const RtNodeSpec& n = s.nodes.rt[i];
    const RtOutcome* out = i < o.rt.size() ? &o.rt[i] : nullptr;
    const double t = out ? out->time_us : kNaN;
    cell[prefix + "workload"] = n.workload.name;
    cell[prefix + "name"] = n.name;
    cell[prefix + "core"] = std::to_string(n.core);
    cell[prefix + "time_us"] = us(t);
    isolation_cells(cell, prefix, first, b.runs(s, n.workload, n.core), t, s, rep);
    if (out) {
      cell[prefix + "response_p99_us"] = us(percentile(out->response_us, 99.0));
      cell[prefix + "response_max_us"] = us(maximum(out->response_us));
      if (out->deadline_misses >= 0)
        cell[prefix + "deadline_misses"] = std::to_string(out->deadline_misses);
    }
    if (first) cell["rt_jobs"] = out ? std::to_string(out->jobs) : "";
  };
  const auto nrt_cells = [&](const std::string& prefix, std::size_t i, bool first) {
    const NrtNodeSpec& n = s.nodes.nrt[i];
    const NrtOutcome* out = i < o.nrt.size() ? &o.nrt[i] : nullptr;
    const double t = out ? out->time_us : kNaN;
    cell[prefix + "workload"] = n.workload.name;
    cell[prefix + "name"] = n.name;
    cell[prefix + "core"] = std::to_string(n.core);
    cell[prefix + "time_us"] = us(t);
    isolation_cells(cell, prefix, first, b.runs(s, n.workload, n.core), t, s, rep);
    cell[prefix + "bandwidth_mbps"] = out ? mbps(out->bandwidth_mbps) : "";
    cell[prefix + "throttle_count"] = out ? std::to_string(out->throttle_count) : "";
    cell[prefix + "throttled_us"] = out ? us(out->throttled_us) : "";
    if (first) {
      cell["nrt_mode"] = std::string(to_string(n.mode));
      cell["nrt_runs"] = out ? fixed(out->runs, 4) : "";
    }
  };
  for (std::size_t i = 0; i < s.nodes.rt.size(); ++i)
    rt_cells(prefix_of("rt", i), i, i == 0);
  for (std::size_t i = 0; i < s.nodes.nrt.size(); ++i)
    nrt_cells(prefix_of("nrt", i), i, i == 0);
  // The fixed names of the first nRT node's throttle columns have no "nrt_" prefix.
  if (!s.nodes.nrt.empty()) {
    cell["throttle_count"] = cell["nrt_throttle_count"];
    cell["throttled_us"] = cell["nrt_throttled_us"];
  }

  const auto delays = values_of(o, "activation_delay");
  const auto callbacks = values_of(o, "pmc_callback");
  cell["activation_delay_p50_us"] = us(median(delays));
  cell["activation_delay_max_us"] = us(maximum(delays));
  cell["pmc_callback_p50_us"] = us(median(callbacks));
  cell["pmc_callback_max_us"] = us(maximum(callbacks));
  cell["sampling_overhead_p50_us"] = us(median(values_of(o, "sampling_overhead")));
  // hw: an RT enable / disable signal from its publish to the controller, and an enable signal
  // from its publish to the first THR entered (samples.csv kinds of the same names).
  cell["signal_latency_p50_us"] = us(median(values_of(o, "signal_latency")));
  cell["signal_to_thr_p50_us"] = us(median(values_of(o, "signal_to_thr")));
  for (const auto& p : point.params)
    cell["param:" + p.path] = p.value.is_string() ? p.value.get<std::string>() : p.value.dump();

  return join_cells(header, cell) + "\n";
}

std::optional<std::string> refresh_isolation_cells(const std::vector<std::string>& header,
                                                   const std::string& line, const Scenario& s,
                                                   const Baselines& b) {
  const std::vector<std::string> cells = csv_split(line);
  if (cells.size() != header.size()) return std::nullopt;
  std::map<std::string, std::string> cell;
  for (std::size_t c = 0; c < header.size(); ++c)
    cell[header[c]] = cells[c];
  bool changed = false;
  const int rep = std::atoi(cell["rep"].c_str());
  const auto refresh = [&](const std::string& prefix, bool first, const BaselineRuns& runs) {
    const std::string t = cell[prefix + "time_us"];
    std::map<std::string, std::string> fresh;
    char* end = nullptr;
    const double time = std::strtod(t.c_str(), &end);  // an empty or odd cell: not measured
    isolation_cells(fresh, prefix, first, runs, !t.empty() && *end == '\0' ? time : kNaN, s, rep);
    for (const auto& [column, value] : fresh)
      if (column != prefix + "slowdown" && cell.count(column) && cell[column] != value)
        changed = true;
    for (const auto& [column, value] : fresh)
      if (cell.count(column)) cell[column] = value;
  };
  // Each key once (it hashes the platform's and the workload's documents).
  for (std::size_t i = 0; i < s.nodes.rt.size(); ++i) {
    const RtNodeSpec& n = s.nodes.rt[i];
    const auto it = b.all().find(Baselines::key(s, n.workload, n.core));
    if (it == b.all().end()) return std::nullopt;
    refresh(prefix_of("rt", i), i == 0, it->second);
  }
  for (std::size_t i = 0; i < s.nodes.nrt.size(); ++i) {
    const NrtNodeSpec& n = s.nodes.nrt[i];
    const auto it = b.all().find(Baselines::key(s, n.workload, n.core));
    if (it == b.all().end()) return std::nullopt;
    refresh(prefix_of("nrt", i), i == 0, it->second);
  }
  if (!changed) return std::nullopt;
  return join_cells(header, cell);
}

std::vector<double> row_node_times(const std::vector<std::string>& header,
                                   const std::vector<std::string>& cells, const Scenario& s) {
  std::vector<double> out;
  const auto time_of = [&](const std::string& column) {
    const auto it = std::find(header.begin(), header.end(), column);
    if (it == header.end()) return kNaN;
    const auto c = static_cast<std::size_t>(it - header.begin());
    if (c >= cells.size() || cells[c].empty()) return kNaN;
    char* end = nullptr;
    const double v = std::strtod(cells[c].c_str(), &end);
    return *end == '\0' ? v : kNaN;
  };
  for (std::size_t i = 0; i < s.nodes.rt.size(); ++i)
    out.push_back(time_of(prefix_of("rt", i) + "time_us"));
  for (std::size_t i = 0; i < s.nodes.nrt.size(); ++i)
    out.push_back(time_of(prefix_of("nrt", i) + "time_us"));
  return out;
}

std::vector<std::string> fill_ci_cells(const std::vector<std::string>& header,
                                       const std::vector<std::string>& lines, const Scenario& s,
                                       const Baselines& b, const RoundPairing& pairing) {
  const auto rep_column = std::find(header.begin(), header.end(), "rep") - header.begin();
  std::map<int, std::vector<double>> times;
  std::vector<std::vector<std::string>> rows;
  for (const auto& line : lines) {
    rows.push_back(csv_split(line));
    const auto& cells = rows.back();
    if (cells.size() != header.size()) continue;
    char* end = nullptr;
    const long rep = std::strtol(cells[static_cast<std::size_t>(rep_column)].c_str(), &end, 10);
    if (*end != '\0' || rep < 0) continue;
    times[static_cast<int>(rep)] = row_node_times(header, cells, s);
  }
  std::vector<const BaselineRuns*> baselines;
  std::vector<std::string> columns;
  const auto node = [&](const std::string& prefix, const WorkloadInfo& w, int core) {
    const auto it = b.all().find(Baselines::key(s, w, core));
    baselines.push_back(it == b.all().end() ? nullptr : &it->second);
    columns.push_back(prefix + "slowdown_ci95_pct");
  };
  for (std::size_t i = 0; i < s.nodes.rt.size(); ++i)
    node(prefix_of("rt", i), s.nodes.rt[i].workload, s.nodes.rt[i].core);
  for (std::size_t i = 0; i < s.nodes.nrt.size(); ++i)
    node(prefix_of("nrt", i), s.nodes.nrt[i].workload, s.nodes.nrt[i].core);
  const std::vector<MeanCi> cis = slowdown_cis(baselines, times, pairing);
  std::map<std::string, std::string> fresh;
  for (std::size_t n = 0; n < cis.size(); ++n)
    fresh[columns[n]] = fixed(cis[n].half_width_pct(), 3);
  std::vector<std::string> out;
  for (std::size_t r = 0; r < rows.size(); ++r) {
    if (rows[r].size() != header.size()) {
      out.push_back(lines[r]);
      continue;
    }
    std::map<std::string, std::string> cell;
    for (std::size_t c = 0; c < header.size(); ++c)
      cell[header[c]] = rows[r][c];
    for (const auto& [column, value] : fresh)
      if (cell.count(column)) cell[column] = value;
    out.push_back(join_cells(header, cell));
  }
  return out;
}

std::string samples_rows(const std::string& point_id, int rep, const PointOutcome& o) {
  std::string out;
  const std::string prefix = point_id + "," + std::to_string(rep) + ",";
  for (const auto& s : o.samples)
    out += prefix + csv_escape(s.kind) + "," + us(s.value_us) + "\n";
  for (std::size_t i = 0; i < o.rt.size(); ++i)
    for (double v : o.rt[i].response_us)
      out += prefix + rt_job_kind(i) + "," + us(v) + "\n";
  return out;
}

std::string csv_escape(const std::string& field) {
  if (field.find_first_of(",\"\n\r") == std::string::npos) return field;
  std::string out = "\"";
  for (char c : field)
    out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::vector<std::string> csv_split(const std::string& line) {
  std::vector<std::string> out(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        out.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        out.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      out.emplace_back();
    } else {
      out.back() += c;
    }
  }
  return out;
}

}  // namespace rosguard

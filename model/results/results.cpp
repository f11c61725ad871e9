#include "results/results.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>

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

double maximum(const std::vector<double>& v) {
  return v.empty() ? kNaN : *std::max_element(v.begin(), v.end());
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
  for (const char* c : {"platform", "nrt_mode", "rt_jobs", "nrt_runs", "reference_mbps",
                        "sampling_overhead_p50_us", "pmc_callback_max_us"})
    h.emplace_back(c);
  for (std::size_t i = 1; i < max_rt; ++i)
    for (const char* c : {"workload", "time_us", "isolation_us", "slowdown"})
      h.push_back("rt" + std::to_string(i) + "_" + c);
  for (std::size_t i = 1; i < max_nrt; ++i)
    for (const char* c : {"workload", "time_us", "isolation_us", "slowdown", "bandwidth_mbps",
                          "throttle_count", "throttled_us"})
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
  cell["sampling"] = std::string(to_string(r.sampling));
  cell["scope"] = std::string(to_string(r.scope));
  cell["threshold_pct"] = compact(r.threshold_pct);
  cell["sampling_period_us"] = std::to_string(r.sampling_period_us);
  cell["regulation_period_us"] = std::to_string(r.regulation_period_us);
  cell["reference_mbps"] = mbps(r.reference_mbps);
  cell["platform"] = s.platform.name;

  const auto rt_cells = [&](const std::string& prefix, std::size_t i, bool first) {
    const RtNodeSpec& n = s.nodes.rt[i];
    const IsolationResult& iso = b.at(s, n.workload, n.core);
    const double t = i < o.rt.size() ? o.rt[i].time_us : kNaN;
    cell[prefix + "workload"] = n.workload.name;
    cell[prefix + "time_us"] = us(t);
    cell[prefix + "isolation_us"] = us(iso.time_us);
    cell[prefix + "slowdown"] = ratio(t / iso.time_us);
    if (first) {
      cell["rt_isolation_ipc"] = ratio(iso.ipc);
      cell["rt_isolation_mbps"] = mbps(iso.mbps);
      cell["rt_jobs"] = i < o.rt.size() ? std::to_string(o.rt[i].jobs) : "";
    }
  };
  const auto nrt_cells = [&](const std::string& prefix, std::size_t i, bool first) {
    const NrtNodeSpec& n = s.nodes.nrt[i];
    const IsolationResult& iso = b.at(s, n.workload, n.core);
    const NrtOutcome* out = i < o.nrt.size() ? &o.nrt[i] : nullptr;
    const double t = out ? out->time_us : kNaN;
    cell[prefix + "workload"] = n.workload.name;
    cell[prefix + "time_us"] = us(t);
    cell[prefix + "isolation_us"] = us(iso.time_us);
    cell[prefix + "slowdown"] = ratio(t / iso.time_us);
    cell[prefix + "bandwidth_mbps"] = out ? mbps(out->bandwidth_mbps) : "";
    cell[prefix + "throttle_count"] = out ? std::to_string(out->throttle_count) : "";
    cell[prefix + "throttled_us"] = out ? us(out->throttled_us) : "";
    if (first) {
      cell["nrt_isolation_ipc"] = ratio(iso.ipc);
      cell["nrt_isolation_mbps"] = mbps(iso.mbps);
      cell["nrt_mode"] = std::string(to_string(n.mode));
      cell["nrt_runs"] = out ? fixed(out->runs, 4) : "";
    }
  };
  for (std::size_t i = 0; i < s.nodes.rt.size(); ++i)
    rt_cells(i == 0 ? "rt_" : "rt" + std::to_string(i) + "_", i, i == 0);
  for (std::size_t i = 0; i < s.nodes.nrt.size(); ++i)
    nrt_cells(i == 0 ? "nrt_" : "nrt" + std::to_string(i) + "_", i, i == 0);
  // The fixed name of the first nRT node's throttle columns has no "nrt_" prefix.
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
  for (const auto& p : point.params)
    cell["param:" + p.path] = p.value.is_string() ? p.value.get<std::string>() : p.value.dump();

  std::string line;
  for (std::size_t c = 0; c < header.size(); ++c) {
    if (c) line += ',';
    auto it = cell.find(header[c]);
    if (it != cell.end()) line += csv_escape(it->second);
  }
  return line + "\n";
}

std::string samples_rows(const std::string& point_id, int rep, const PointOutcome& o) {
  std::string out;
  const std::string prefix = point_id + "," + std::to_string(rep) + ",";
  for (const auto& s : o.samples)
    out += prefix + csv_escape(s.kind) + "," + us(s.value_us) + "\n";
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

#include "run/unregulated.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/hash.h"
#include "load/files.h"
#include "policy/policy.h"
#include "results/precision.h"
#include "results/results.h"
#include "store/results_store.h"

namespace rosguard {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr const char* kFile = "unregulated.json";

// As points_row writes numbers: fixed decimals, empty when not measured.
std::string fixed(double v, int decimals) {
  if (!std::isfinite(v)) return "";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  std::string s = buf;
  if (s == "-0" || s.find_first_not_of("-0.") == std::string::npos) s = s.substr(s[0] == '-');
  return s;
}

json times_json(const std::vector<double>& v) {
  json a = json::array();
  for (double x : v)
    a.push_back(std::isfinite(x) ? json(x) : json(nullptr));
  return a;
}

std::vector<double> times_from(const json& a) {
  std::vector<double> v;
  for (const auto& x : a)
    v.push_back(number_or_nan(x));
  return v;
}

}  // namespace

bool UnregulatedCoruns::needed(const Scenario& s) {
  const PolicyInfo* policy = find_builtin_policy(s.regulation.policy);
  const bool regulates = !policy || policy->traits.regulates;
  return regulates && !s.nodes.rt.empty() && !s.nodes.nrt.empty() && !signalled_elsewhere(s);
}

bool UnregulatedCoruns::signalled_elsewhere(const Scenario& s) {
  return std::any_of(s.nodes.rt.begin(), s.nodes.rt.end(),
                     [](const RtNodeSpec& n) { return n.signal == RtSignal::Topic; });
}

std::string UnregulatedCoruns::key(const Scenario& s) {
  json doc = s.document;
  // Nothing of the regulation, nor how often or under which name the scenario runs.
  for (const char* k : {"regulation", "repetitions", "name", "description", "$schema", "sweep"})
    doc.erase(k);
  if (doc.contains("hw") && doc["hw"].is_object())
    for (const char* k :
         {"baseline_repetitions", "precision_pct", "max_repetitions", "adjacent_baselines"})
      doc["hw"].erase(k);
  // Regulation settings a node may carry (a per-node budget) do not change an unregulated run.
  if (doc.contains("nodes") && doc["nodes"].is_object())
    for (const char* group : {"rt", "nrt"})
      if (doc["nodes"].contains(group) && doc["nodes"][group].is_array())
        for (auto& node : doc["nodes"][group])
          if (node.is_object())
            for (const char* k : {"budget_mbps", "regulation", "threshold_pct"})
              node.erase(k);
  // FNV-1a of the backend, the platform's document hash, that document and each node's
  // workload document hash (SharedJson::hash).
  const auto hex = [](std::uint64_t v) {
    char b[20];
    std::snprintf(b, sizeof b, "/%016llx", static_cast<unsigned long long>(v));
    return std::string(b);
  };
  std::string context = s.backend + hex(s.platform.doc.hash()) + "/" + doc.dump();
  std::string names;
  for (const auto& n : s.nodes.rt) {
    context += hex(n.workload.doc.hash());
    names += (names.empty() ? "" : "+") + n.workload.name;
  }
  for (const auto& n : s.nodes.nrt) {
    context += hex(n.workload.doc.hash());
    names += "+" + n.workload.name;
  }
  char buf[20];
  std::snprintf(buf, sizeof buf, "%08llx",
                static_cast<unsigned long long>(fnv1a(context) & 0xffffffffULL));
  return "corun/" + names + "/" + buf;
}

Scenario UnregulatedCoruns::scenario_of(const Scenario& point) {
  Scenario s = point;
  // Nothing of the point's setting leaks into the co-run: every point of a key (whichever a
  // shard meets first) gives the same one. Only what defines the measurement stays.
  RegulationSpec r;
  r.policy = "none";
  r.metric = point.regulation.metric;
  r.reference_mbps = point.regulation.reference_mbps;
  r.reference_from_platform = point.regulation.reference_from_platform;
  s.regulation = r;
  nlohmann::json doc = {{"policy", "none"},
                        {"sampling", std::string(to_string(r.sampling))},
                        {"sampling_period_us", r.sampling_period_us},
                        {"regulation_period_us", r.regulation_period_us},
                        {"threshold_pct", r.threshold_pct},
                        {"scope", std::string(to_string(r.scope))}};
  if (s.document.contains("regulation") && s.document["regulation"].is_object())
    for (const char* k : {"metric", "reference_mbps"})
      if (s.document["regulation"].contains(k)) doc[k] = s.document["regulation"][k];
  s.document["regulation"] = doc;
  return s;
}

void UnregulatedCoruns::put(const std::string& key, CorunResult result, int rep) {
  by_key_[key][rep] = std::move(result);
}

bool UnregulatedCoruns::has(const std::string& key, int rep) const {
  const auto it = by_key_.find(key);
  return it != by_key_.end() && it->second.count(rep) > 0;
}

std::optional<CorunResult> UnregulatedCoruns::median(const std::string& key) const {
  const auto it = by_key_.find(key);
  if (it == by_key_.end() || it->second.empty()) return std::nullopt;
  const auto node_medians = [&](auto member) {
    std::size_t nodes = 0;
    for (const auto& [rep, r] : it->second)
      nodes = std::max(nodes, (r.*member).size());
    std::vector<double> out;
    for (std::size_t i = 0; i < nodes; ++i) {
      std::vector<double> v;
      for (const auto& [rep, r] : it->second)
        v.push_back(i < (r.*member).size() ? (r.*member)[i] : kNaN);
      out.push_back(finite_median(v));
    }
    return out;
  };
  return CorunResult{node_medians(&CorunResult::rt_time_us),
                     node_medians(&CorunResult::nrt_time_us)};
}

json UnregulatedCoruns::to_json() const {
  json doc = json::object();
  for (const auto& [key, runs] : by_key_) {
    const CorunResult m = *median(key);
    json each = json::array();
    for (const auto& [rep, r] : runs)
      each.push_back({{"rep", rep},
                      {"rt_time_us", times_json(r.rt_time_us)},
                      {"nrt_time_us", times_json(r.nrt_time_us)}});
    doc[key] = {{"rt_time_us", times_json(m.rt_time_us)},
                {"nrt_time_us", times_json(m.nrt_time_us)},
                {"runs", each}};
  }
  return doc;
}

UnregulatedCoruns UnregulatedCoruns::from_json(const json& doc) {
  UnregulatedCoruns out;
  if (!doc.is_object()) throw json::other_error::create(501, "not a JSON object", nullptr);
  for (const auto& [key, entry] : doc.items())
    for (const auto& r : entry.at("runs"))
      out.put(key, {times_from(r.at("rt_time_us")), times_from(r.at("nrt_time_us"))},
              r.at("rep").get<int>());
  return out;
}

UnregulatedCoruns UnregulatedCoruns::read(const fs::path& dir) {
  std::error_code ec;
  const fs::path path = dir / kFile;
  if (!fs::exists(path, ec)) return {};
  try {
    return from_json(json::parse(read_file(path), nullptr, false));
  } catch (const json::exception& e) {
    throw RunError(path.string() + ": not the unregulated co-runs rosguard writes (" + e.what() +
                   "); remove it to measure them again");
  }
}

void UnregulatedCoruns::save(const fs::path& dir) const {
  FileLock lock(dir / ".lock");
  UnregulatedCoruns merged = read(dir);
  for (const auto& [key, runs] : by_key_)
    for (const auto& [rep, r] : runs)
      if (!merged.has(key, rep)) merged.put(key, r, rep);
  write_file_atomic(dir / kFile, merged.to_json().dump(2) + "\n");
}

std::size_t UnregulatedCoruns::measurements() const {
  std::size_t n = 0;
  for (const auto& [key, runs] : by_key_)
    n += runs.size();
  return n;
}

std::string fill_unregulated_cells(const std::vector<std::string>& header, const std::string& line,
                                   const Scenario& s, const std::string& corun_key,
                                   const UnregulatedCoruns& coruns, const Baselines& baselines) {
  std::vector<std::string> cells = csv_split(line);
  if (cells.size() != header.size()) return line;
  const auto at = [&](const std::string& column) -> std::string* {
    const auto it = std::find(header.begin(), header.end(), column);
    return it == header.end() ? nullptr : &cells[static_cast<std::size_t>(it - header.begin())];
  };
  bool changed = false;
  const auto set = [&](const std::string& column, const std::string& value) {
    std::string* cell = at(column);
    if (cell && *cell != value) {
      *cell = value;
      changed = true;
    }
  };
  // Node i's pair of cells: its prefix "rt" / "nrt" for the first node, "rt1", "nrt2", ... after.
  const auto prefix = [](bool rt, std::size_t i) {
    return std::string(rt ? "rt" : "nrt") + (i ? std::to_string(i) : "");
  };
  const auto count = [&](bool rt) { return rt ? s.nodes.rt.size() : s.nodes.nrt.size(); };
  if (s.regulation.policy == "none") {
    for (const bool rt : {true, false})
      for (std::size_t i = 0; i < count(rt); ++i) {
        const std::string* time = at(prefix(rt, i) + "_time_us");
        const std::string* slowdown = at(prefix(rt, i) + "_slowdown");
        if (time) set(prefix(rt, i) + "_unregulated_time_us", *time);
        if (slowdown) set(prefix(rt, i) + "_unregulated_slowdown", *slowdown);
      }
  } else if (UnregulatedCoruns::needed(s)) {
    const auto m = coruns.median(corun_key);
    if (!m) return line;
    // The co-run's own scenario keys its adjacent baselines (built only for them: rows are many).
    std::optional<Scenario> c;
    if (s.hw.adjacent_baselines) c = UnregulatedCoruns::scenario_of(s);
    // Node i's slowdown in the co-run. With hw.adjacent_baselines each run of the co-run against
    // its own baselines, measured right before it: the median of those ratios; else the median
    // time over the isolation baselines' median.
    const auto slowdown = [&](bool rt, std::size_t i, const WorkloadInfo& w, int core) {
      if (!s.hw.adjacent_baselines)
        return baselines.all().count(Baselines::key(s, w, core))
                   ? (rt ? m->rt_time_us : m->nrt_time_us)[i] / baselines.at(s, w, core).time_us
                   : kNaN;
      const auto it = baselines.all().find(Baselines::key(*c, w, core));
      if (it == baselines.all().end()) return kNaN;
      std::vector<double> ratios;
      for (const auto& [rep, run] : coruns.all().at(corun_key)) {
        const std::vector<double>& t = rt ? run.rt_time_us : run.nrt_time_us;
        if (i < t.size())
          ratios.push_back(t[i] / round_baseline_us(it->second, rep, adjacent_pairing()));
      }
      return median(ratios);
    };
    for (const bool rt : {true, false}) {
      const std::vector<double>& times = rt ? m->rt_time_us : m->nrt_time_us;
      for (std::size_t i = 0; i < times.size() && i < count(rt); ++i) {
        const WorkloadInfo& w = rt ? s.nodes.rt[i].workload : s.nodes.nrt[i].workload;
        const int core = rt ? s.nodes.rt[i].core : s.nodes.nrt[i].core;
        set(prefix(rt, i) + "_unregulated_time_us", fixed(times[i], 3));
        set(prefix(rt, i) + "_unregulated_slowdown", fixed(slowdown(rt, i, w, core), 6));
      }
    }
  }
  if (!changed) return line;
  std::string out;
  for (std::size_t c = 0; c < cells.size(); ++c)
    out += (c ? "," : "") + csv_escape(cells[c]);
  return out;
}

}  // namespace rosguard

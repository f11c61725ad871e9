#include "store/run_manifest.h"

#include <cstdio>
#include <iterator>
#include <map>
#include <set>
#include <utility>
#include <vector>

#include "core/hash.h"
#include "load/host_facts.h"
#include "run/parallel.h"

namespace rosguard {
using json = nlohmann::json;

namespace {

json describe_points(const LoadedScenario& loaded, unsigned threads) {
  std::vector<json> each(loaded.points.size());
  parallel_for(each.size(), threads, [&](std::size_t i) {
    const SweepPoint& p = loaded.points[i].sweep;
    json params = json::object();
    for (const auto& q : p.params)
      params[q.path] = q.value;
    each[i] = {{"index", p.index}, {"id", p.id}, {"params", std::move(params)}};
  });
  return json::array_t(std::make_move_iterator(each.begin()), std::make_move_iterator(each.end()));
}

// Every workload the run uses, with the isolation figures it is calibrated against (the paper's
// Table 1), so that analysis can show measured next to reference.
json describe_workloads(const LoadedScenario& loaded) {
  json workloads = json::object();
  std::set<std::pair<std::string, std::string>> seen;  // (name, origin): each entry made once
  const WorkloadInfo* last = nullptr;  // the points of a sweep mostly share their workloads
  const auto add = [&](const WorkloadInfo& w) {
    if (last && last->name == w.name && last->origin == w.origin) return;
    last = &w;
    if (!seen.emplace(w.name, w.origin).second) return;
    json entry{{"origin", w.origin}};
    if (w.doc.contains("reference")) entry["reference"] = w.doc["reference"];
    workloads[w.name] = entry;
  };
  for (const auto& p : loaded.points) {
    for (const auto& n : p.scenario.nodes.rt)
      add(n.workload);
    for (const auto& n : p.scenario.nodes.nrt)
      add(n.workload);
  }
  return workloads;
}

json describe_platform(const LoadedScenario& loaded) {
  std::map<std::string, json> platforms;
  for (const auto& p : loaded.points)
    if (!platforms.count(p.scenario.platform.name))  // the document copied once
      platforms.emplace(p.scenario.platform.name, json{{"origin", p.scenario.platform.origin},
                                                       {"doc", p.scenario.platform.doc}});
  return platforms.size() == 1 ? platforms.begin()->second : json(platforms);
}

}  // namespace

std::string scenario_hash(const LoadedScenario& s) {
  json j = s.expanded;
  for (const char* k : {"name", "description", "repetitions", "$schema"})
    j.erase(k);
  // How often points are repeated does not change one run: a resumed run may ask for more
  // repetitions, a tighter precision or a higher cap.
  if (j.contains("hw") && j["hw"].is_object())
    for (const char* k : {"precision_pct", "max_repetitions"})
      j["hw"].erase(k);
  char buf[20];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(fnv1a(j.dump())));
  return buf;
}

json describe_run(const LoadedScenario& loaded, const std::string& backend,
                  const std::string& command_line, unsigned threads) {
  const Scenario& first = loaded.points.front().scenario;
  json m;
  m["schema_version"] = 1;
  m["tool"] = tool_facts();
  m["command"] = command_line;
  m["scenario_file"] = loaded.file;
  m["scenario_hash"] = scenario_hash(loaded);
  m["scenario"] = {{"given", loaded.given}, {"expanded", loaded.expanded}};
  m["scenario"]["points"] = describe_points(loaded, threads);
  m["workloads"] = describe_workloads(loaded);
  m["platform"] = describe_platform(loaded);
  // "platform": "host": the probe and where the model came from, per backend.
  if (!loaded.host_platform.is_null()) m["host_platform"] = loaded.host_platform;
  m["backend"] = backend;
  m["seed"] = first.seed;
  m["repetitions"] = first.repetitions;
  m["host"] = host_facts();
  m["start_time"] = iso_time_now();
  m["warnings"] = loaded.warnings;
  // sim on a fitted platform: the parameters that rest mostly on their priors (platform "fit"),
  // so that whoever reads the results (rosguard compare) sees how uncertain the model is.
  json dominated = json::array();
  if (backend == "sim")
    for (const auto& p : loaded.points) {
      const nlohmann::json& doc = p.scenario.platform.doc.get();
      if (doc.contains("fit") && !doc["fit"]["prior_dominated"].empty()) {
        dominated = doc["fit"]["prior_dominated"];
        break;
      }
    }
  m["prior_dominated"] = dominated;
  // Where a policy's own defaults (memguard: overflow sampling, 1 ms periods) filled in keys.
  json defaults = json::array();
  for (const auto& [what, points] : loaded.policy_defaults)
    defaults.push_back({{"default", what}, {"points", points}});
  m["policy_defaults"] = defaults;
  return m;
}

}  // namespace rosguard

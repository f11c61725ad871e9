#include "backend/backend.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <vector>

#include "core/error.h"
#include "core/hash.h"
#include "results/results.h"

namespace rosguard {

IsolationResult BaselineRuns::median() const {
  std::vector<double> t, ipc, mbps;
  for (const auto& [rep, r] : runs) {
    t.push_back(r.time_us);
    ipc.push_back(r.ipc);
    mbps.push_back(r.mbps);
  }
  return {finite_median(t), finite_median(ipc), finite_median(mbps)};
}

double BaselineRuns::time_cv() const {
  std::vector<double> t;
  for (const auto& [rep, r] : runs)
    if (std::isfinite(r.time_us)) t.push_back(r.time_us);
  return coefficient_of_variation(t);
}

std::string BaselineRuns::noise_warning(const std::string& key) const {
  if (!too_noisy()) return "";
  char cv[32];
  std::snprintf(cv, sizeof cv, "%.1f", 100.0 * time_cv());
  return "isolation baseline " + key + ": its time varies by " + cv +
         " % (coefficient of variation over " + std::to_string(count()) +
         " measurements, above 5 %); this host is too noisy for slowdown differences of that "
         "order (quiet the machine; raise repetitions or set hw.precision_pct; "
         "hw.adjacent_baselines divides each repetition by measurements taken right before it)";
}

int baseline_round(int k, int repetitions, int measurements) {
  return static_cast<int>(static_cast<long long>(k) * repetitions / measurements);
}

std::string Baselines::key(const Scenario& s, const WorkloadInfo& workload, int core) {
  // How many times a baseline is measured does not change one measurement.
  const auto without_repetition_keys = [](nlohmann::json doc) {
    for (const char* k :
         {"baseline_repetitions", "precision_pct", "max_repetitions", "adjacent_baselines"})
      doc.erase(k);
    return doc;
  };
  const nlohmann::json hw = without_repetition_keys(s.document.at("hw"));
  // FNV-1a of the backend, the platform's and the workload's document hashes (SharedJson::hash:
  // made once per document, not once per row) and the sim and hw settings; with adjacent
  // baselines, of the whole point too (each point has baselines of its own).
  char hashes[40];
  std::snprintf(hashes, sizeof hashes, "/%016llx/%016llx/",
                static_cast<unsigned long long>(s.platform.doc.hash()),
                static_cast<unsigned long long>(workload.doc.hash()));
  std::string identity = s.backend + hashes + s.document.at("sim").dump() + hw.dump();
  if (s.hw.adjacent_baselines) {
    nlohmann::json point = s.document;
    point.erase("repetitions");
    point["hw"] = hw;
    identity += point.dump();
  }
  const std::uint64_t h = fnv1a(identity);
  char buf[20];
  std::snprintf(buf, sizeof buf, "%08llx", static_cast<unsigned long long>(h & 0xffffffffULL));
  return workload.name + "/core" + std::to_string(core) + "/" + buf;
}

const BaselineRuns& Baselines::runs(const Scenario& s, const WorkloadInfo& workload,
                                    int core) const {
  const std::string k = key(s, workload, core);
  auto it = by_key_.find(k);
  if (it == by_key_.end() || it->second.runs.empty())
    throw RunError("no isolation baseline for " + k);
  return it->second;
}

IsolationResult Baselines::at(const Scenario& s, const WorkloadInfo& workload, int core) const {
  return runs(s, workload, core).median();
}

std::uint64_t task_seed(std::uint64_t scenario_seed, std::string_view id, int rep) {
  // splitmix64 over FNV-1a of the id: well spread, and stable across runs and machines.
  std::uint64_t z =
      scenario_seed ^ fnv1a(id) ^ (static_cast<std::uint64_t>(rep) * 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

}  // namespace rosguard

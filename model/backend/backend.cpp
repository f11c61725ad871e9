#include "backend/backend.h"

#include <cstdio>
#include <stdexcept>

#include "core/error.h"
#include "core/hash.h"

namespace rosguard {

std::string Baselines::key(const Scenario& s, const WorkloadInfo& workload, int core) {
  const std::string context = s.backend + s.platform.doc.dump() + workload.doc.dump() +
                              s.document.at("sim").dump() + s.document.at("hw").dump();
  char buf[20];
  std::snprintf(buf, sizeof buf, "%08llx",
                static_cast<unsigned long long>(fnv1a(context) & 0xffffffffULL));
  return workload.name + "/core" + std::to_string(core) + "/" + buf;
}

const IsolationResult& Baselines::at(const Scenario& s, const WorkloadInfo& workload,
                                     int core) const {
  const std::string k = key(s, workload, core);
  auto it = by_key_.find(k);
  if (it == by_key_.end()) throw RunError("no isolation baseline for " + k);
  return it->second;
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

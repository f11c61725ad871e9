#include "platform/residency.h"

#include <algorithm>
#include <cmath>

namespace rosguard::sim {
namespace {

// An occupancy this close to its target (relative to the capacity) has reached it.
constexpr double kSnap = 1e-9;

const Phase* curve_phase(const CoreDemand& d) {
  return d.phase ? d.phase : d.resident_phase;
}

}  // namespace

L3Residency::L3Residency(const ContentionModel& model, const SimPlatform& platform)
    : model_(model),
      capacity_kb_(platform.l3.capacity_kb),
      line_kb_(platform.line_bytes / 1024.0) {}

void L3Residency::advance(double now_ns, std::span<const CoreDemand> demands) {
  const std::size_t n = demands.size();
  const double dt = std::max(0.0, now_ns - last_ns_);
  last_ns_ = now_ns;
  for (std::size_t k = 0; k < kb_.size() && k < n; ++k) {
    if (rate_[k] == 0.0) continue;
    double kb = kb_[k] + rate_[k] * dt;
    kb = rate_[k] > 0.0 ? std::min(kb, target_[k]) : std::max(kb, target_[k]);
    kb_[k] = std::clamp(kb, 0.0, capacity_kb_);
  }
  owner_.resize(n, nullptr);
  kb_.resize(n, 0.0);
  rate_.assign(n, 0.0);
  hits_.assign(n, 1.0);
  key_.clear();
  for (const CoreDemand& d : demands) {
    key_.push_back(static_cast<std::uintptr_t>(d.cluster));
    key_.push_back(d.resident ? 1 : 0);
    key_.push_back(reinterpret_cast<std::uintptr_t>(d.resident_phase ? d.resident_phase : d.phase));
  }
  auto memo = targets_memo_.find(key_);
  if (memo == targets_memo_.end()) {
    if (targets_memo_.size() > 4096) targets_memo_.clear();
    memo = targets_memo_.emplace(key_, model_.occupancies(demands)).first;
  }
  target_ = memo->second;
  for (std::size_t k = 0; k < n; ++k) {
    const CoreDemand& d = demands[k];
    if (d.workload == nullptr) {  // holds nothing
      owner_[k] = nullptr;
      kb_[k] = 0.0;
      continue;
    }
    if (owner_[k] != d.workload) {  // first seen, or another workload: warm
      owner_[k] = d.workload;
      kb_[k] = target_[k];
    }
    if (std::abs(kb_[k] - target_[k]) <= kSnap * capacity_kb_) kb_[k] = target_[k];
    if (const Phase* ph = curve_phase(d)) hits_[k] = 1.0 - ph->mrc.miss_ratio(kb_[k]);
  }
}

double L3Residency::set_rates(std::span<const CoreDemand> demands, const MemoryState& state) {
  const std::size_t n = std::min(demands.size(), kb_.size());
  // Every running core inserts a line per L3 miss; one below its target grows by it.
  std::vector<double> insert(n, 0.0);
  for (std::size_t k = 0; k < n; ++k) {
    const CoreDemand& d = demands[k];
    if (d.phase == nullptr) continue;
    insert[k] = line_kb_ * model_
                               .rates(*d.phase, hits_[k], d.cluster, state,
                                      k < state.slc_hit.size() ? state.slc_hit[k] : 0.0)
                               .l3_refill_per_ns;
    if (owner_[k] != nullptr && kb_[k] < target_[k]) rate_[k] = insert[k];
  }
  // The lines of the cores above their targets are the least recently used: every insertion of
  // a co-runner evicts one of them.
  for (std::size_t k = 0; k < n; ++k) {
    if (owner_[k] == nullptr || kb_[k] <= target_[k]) continue;
    double excess = 0.0, others = 0.0;
    for (std::size_t j = 0; j < n; ++j) {
      if (demands[j].cluster != demands[k].cluster) continue;
      if (owner_[j] != nullptr && kb_[j] > target_[j]) excess += kb_[j] - target_[j];
      if (j != k) others += insert[j];
    }
    rate_[k] = -others * (kb_[k] - target_[k]) / excess;
  }
  // The first time an occupancy reaches its target or crosses a level of the capacity.
  double next = -1.0;
  const double level = capacity_kb_ / kLevels;
  for (std::size_t k = 0; k < n; ++k) {
    if (rate_[k] == 0.0) continue;
    const double c = kb_[k] / level;  // on a level already (rounding): the next one
    const double to = rate_[k] > 0.0 ? std::min(target_[k], (std::floor(c + 1e-9) + 1.0) * level)
                                     : std::max(target_[k], (std::ceil(c - 1e-9) - 1.0) * level);
    const double t = (to - kb_[k]) / rate_[k];
    if (next < 0.0 || t < next) next = std::max(0.0, t);
  }
  return next;
}

}  // namespace rosguard::sim

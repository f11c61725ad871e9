#include "platform/residency.h"

#include <algorithm>
#include <cmath>

namespace rosguard::sim {
namespace {

// A residency this close to its target (relative to the footprint) has reached it.
constexpr double kSnap = 1e-9;

}  // namespace

L3Residency::L3Residency(const ContentionModel& model, const SimPlatform& platform)
    : model_(model),
      capacity_kb_(platform.l3.capacity_kb),
      exponent_(platform.l3.capacity_exponent),
      line_kb_(platform.line_bytes / 1024.0) {}

double L3Residency::cf(double kb, double footprint_kb) const {
  if (footprint_kb <= 0.0) return 1.0;
  return std::pow(std::clamp(kb / footprint_kb, 0.0, 1.0), exponent_);
}

void L3Residency::advance(double now_ns, std::span<const CoreDemand> demands) {
  const std::size_t n = demands.size();
  const double dt = std::max(0.0, now_ns - last_ns_);
  last_ns_ = now_ns;
  for (std::size_t k = 0; k < kb_.size() && k < n; ++k) {
    if (rate_[k] == 0.0) continue;
    double kb = kb_[k] + rate_[k] * dt;
    kb = rate_[k] > 0.0 ? std::min(kb, target_[k]) : std::max(kb, target_[k]);
    kb_[k] = std::clamp(kb, 0.0, footprint_[k]);
  }
  seen_.resize(n, false);
  footprint_.resize(n, 0.0);
  kb_.resize(n, 0.0);
  rate_.assign(n, 0.0);
  capf_.assign(n, 1.0);
  const std::vector<double> share = model_.shares(demands);
  target_ = share;
  for (std::size_t k = 0; k < n; ++k) {
    const double f = demands[k].footprint_kb;
    if (f <= 0.0) {
      seen_[k] = false;
      footprint_[k] = 0.0;
      kb_[k] = 0.0;
      continue;
    }
    if (!seen_[k] || footprint_[k] != f) {  // first seen, or another workload: warm
      seen_[k] = true;
      footprint_[k] = f;
      kb_[k] = target_[k];
    }
    if (std::abs(kb_[k] - target_[k]) <= kSnap * f) kb_[k] = target_[k];
    capf_[k] = cf(kb_[k], f);
  }
}

double L3Residency::set_rates(std::span<const CoreDemand> demands, const MemoryState& state) {
  const std::size_t n = std::min(demands.size(), kb_.size());
  // Per cluster: the insertions of the running cores and the cores above their targets.
  std::vector<double> insert(n, 0.0);
  for (std::size_t k = 0; k < n; ++k) {
    const CoreDemand& d = demands[k];
    if (d.phase == nullptr) continue;
    const CoreRates r = model_.rates(*d.phase, d.l3_hit, d.cluster, capf_[k], state);
    insert[k] = line_kb_ * r.l3_refill_per_ns;
    if (footprint_[k] > 0.0 && kb_[k] < target_[k])
      rate_[k] = line_kb_ * d.l3_hit * (1.0 - capf_[k]) * r.refill_per_ns;
  }
  for (std::size_t k = 0; k < n; ++k) {
    if (footprint_[k] <= 0.0 || kb_[k] <= target_[k]) continue;
    double excess = 0.0, others = 0.0;
    for (std::size_t j = 0; j < n; ++j) {
      if (demands[j].cluster != demands[k].cluster) continue;
      if (footprint_[j] > 0.0 && kb_[j] > target_[j]) excess += kb_[j] - target_[j];
      if (j != k) others += insert[j];
    }
    rate_[k] = -others * (kb_[k] - target_[k]) / excess;
  }
  // The first time a residency reaches its target or crosses a level of its capacity factor.
  double next = -1.0;
  const auto at_cf = [&](double c, double f) {
    return exponent_ > 0.0 ? f * std::pow(std::clamp(c, 0.0, 1.0), 1.0 / exponent_) : f;
  };
  for (std::size_t k = 0; k < n; ++k) {
    if (rate_[k] == 0.0) continue;
    const double f = footprint_[k];
    const double c = capf_[k] * kLevels;  // on a level already (rounding): the next one
    double to = target_[k];
    if (exponent_ > 0.0) {
      if (rate_[k] > 0.0)
        to = std::min(to, at_cf((std::floor(c + 1e-9) + 1.0) / kLevels, f));
      else
        to = std::max(to, at_cf((std::ceil(c - 1e-9) - 1.0) / kLevels, f));
    }
    const double t = (to - kb_[k]) / rate_[k];
    if (next < 0.0 || t < next) next = std::max(0.0, t);
  }
  return next;
}

}  // namespace rosguard::sim

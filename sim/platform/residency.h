// Refill after throttling: how much of each core's footprint its cluster's L3 holds, over time.
//
// The steady-state memory model (contention.h) gives each resident core a share S of the L3
// (water-filling by insertion pressure; S = F, its footprint, where the footprints fit). A core
// that stops running (throttled, idle between RT jobs, finished) keeps its lines only until
// co-runners' insertions push them out, and when it runs again it refetches what it lost. Each
// core k of a cluster holds R_k KB of its footprint F_k (0 <= R_k <= F_k); its target T_k is its
// water-filling share while resident, 0 while not. With line size b, per ns:
//
//   insertions   I_k = b * l3_refill_k                    (every L3 miss allocates a line)
//   refill       G_k = b * l3_hit_k * (1 - cf(R_k)) * refill_k   if k runs and R_k < T_k
//                      (the misses to its own footprint: each brings one footprint line back)
//   eviction     E_k = (sum_{j running, j != k} I_j) * (R_k - T_k) / sum_{l: R_l > T_l} (R_l - T_l)
//                      if R_k > T_k (the lines nobody touches are the LRU ones: whatever the
//                      co-runners insert evicts them, split by how far each is above its target)
//   dR_k / dt = G_k - E_k, clamped at T_k;   cf(R) = min(1, R / F)^capacity_exponent
//
// (refill_k, l3_refill_k: lines per ns from ContentionModel::rates()). So a throttled core beside
// a streaming co-runner loses residency at the rate the co-runner inserts; alone it keeps it; on
// resuming it misses on its footprint (l3_hit * (1 - cf) of its L2 refills more than when warm)
// until those misses have brought back what it lost: a refill costs exactly the lost lines in
// extra misses, whatever the exponent. A core is warm (R = T) when first seen.
//
// Loosely timed: rates are constant between memory re-solves, so R moves linearly; the memory
// system re-solves when some R crosses a level of its capacity factor (cf in steps of 1 /
// kLevels) or reaches its target, at the next quantum boundary.
//
// Contract: pure C++, deterministic; one instance per memory system.
#pragma once

#include <span>
#include <vector>

#include "platform/contention.h"

namespace rosguard::sim {

class L3Residency {
 public:
  // Capacity-factor levels between re-solves while a residency moves (discretisation, like the
  // quantum: a core's hit ratio is updated when it has moved by 1 / kLevels).
  static constexpr int kLevels = 32;

  L3Residency(const ContentionModel& model, const SimPlatform& platform);

  // Brings every residency from the time of the last update() to `now_ns` at the rates then in
  // force, then takes the new demands (one per core, fixed order): targets, and the capacity
  // factor each core runs with from now (cf of its residency). Cores seen for the first time
  // start warm.
  void advance(double now_ns, std::span<const CoreDemand> demands);
  // With the state solved for capacity_factors(): the rates of change, and the time (ns from
  // the last advance) at which some residency crosses a level or reaches its target
  // (-1: nothing moves).
  double set_rates(std::span<const CoreDemand> demands, const MemoryState& state);

  const std::vector<double>& capacity_factors() const { return capf_; }
  double resident_kb(std::size_t core) const { return kb_[core]; }
  double target_kb(std::size_t core) const { return target_[core]; }
  double rate_kb_per_ns(std::size_t core) const { return rate_[core]; }

 private:
  double cf(double kb, double footprint_kb) const;

  const ContentionModel& model_;
  double capacity_kb_;
  double exponent_;
  double line_kb_;
  double last_ns_ = 0.0;
  std::vector<bool> seen_;
  std::vector<double> footprint_;
  std::vector<double> kb_;
  std::vector<double> target_;
  std::vector<double> rate_;
  std::vector<double> capf_;
};

}  // namespace rosguard::sim

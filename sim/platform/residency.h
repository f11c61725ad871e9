// Refill after throttling: how much of the L3 each core holds, over time.
//
// The steady-state memory model (contention.h) gives each resident core an occupancy T_k of its
// cluster's L3: the natural partition of shared LRU (model/cache/shared_lru.h). A core that
// stops running (throttled, idle between RT jobs, finished) keeps its lines only until
// co-runners' insertions push them out, and when it runs again it misses on what it lost and
// inserts it back. Each core k holds R_k KB of its cluster's L3 (0 <= R_k <= capacity); its
// target T_k is its occupancy in the partition while resident, 0 while not. With line size b,
// m_k the curve of the phase k runs and refill_k its L2 refills per ns (ContentionModel::rates()
// at the hit ratio 1 - m_k(R_k)), per ns:
//
//   insertions  I_k = b * m_k(R_k) * refill_k                (every L3 miss allocates a line)
//   growth      dR_k/dt = I_k                     if k runs and R_k < T_k
//               (its lines are the most recently used: what it inserts evicts the oldest lines,
//               those of cores above their targets, never its own: the HOTL growth dc/dt of the
//               shared-cache model, so a cold core alone refills along its own footprint curve)
//   eviction    dR_k/dt = -(sum_{j runs, j != k} I_j) * (R_k - T_k) / sum_{l: R_l > T_l} (R_l -
//   T_l)
//               if R_k > T_k (the lines nobody touches are the LRU ones: whatever the
//               co-runners insert evicts them, split by how far each is above its target)
//   both clamped at T_k; the hit ratio a core runs with is 1 - m_k(R_k).
//
// So a throttled core beside a streaming co-runner loses its lines at the rate the co-runner
// inserts; alone it keeps them; on resuming it misses more (m(R) > m(T)) and sends more to the
// DRAM until it has inserted back what it lost. No parameter of
// its own: line size, capacity, the curves and the rates are the model's. A core is warm
// (R = T) when first seen or when it runs another workload.
//
// Loosely timed: rates are constant between memory re-solves, so R moves linearly; the memory
// system re-solves when some R crosses a multiple of capacity / kLevels or reaches its target,
// at the next quantum boundary.
//
// Contract: pure C++, deterministic; one instance per memory system.
#pragma once

#include <cstdint>
#include <map>
#include <span>
#include <vector>

#include "platform/contention.h"

namespace rosguard::sim {

class L3Residency {
 public:
  // Levels of the L3 capacity between re-solves while an occupancy moves (discretisation, like
  // the quantum: a core's hit ratio is updated when it has moved by capacity / kLevels).
  static constexpr int kLevels = 32;

  L3Residency(const ContentionModel& model, const SimPlatform& platform);

  // Brings every occupancy from the time of the last update() to `now_ns` at the rates then in
  // force, then takes the new demands (one per core, fixed order): targets, and the hit ratio
  // each core runs with from now (its phase's curve at its occupancy). Cores seen for the first
  // time, or with another workload, start warm.
  void advance(double now_ns, std::span<const CoreDemand> demands);
  // With the state solved for hits(): the rates of change, and the time (ns from the last
  // advance) at which some occupancy crosses a level or reaches its target (-1: nothing moves).
  double set_rates(std::span<const CoreDemand> demands, const MemoryState& state);

  const std::vector<double>& hits() const { return hits_; }
  double resident_kb(std::size_t core) const { return kb_[core]; }
  double target_kb(std::size_t core) const { return target_[core]; }
  double rate_kb_per_ns(std::size_t core) const { return rate_[core]; }

 private:
  const ContentionModel& model_;
  double capacity_kb_;
  double line_kb_;
  double last_ns_ = 0.0;
  std::vector<const void*> owner_;  // the workload whose lines the core holds (null: none)
  std::vector<double> kb_;
  std::vector<double> target_;
  std::vector<double> rate_;
  std::vector<double> hits_;
  // Targets by what they depend on (per demand: cluster, resident, the phase of its curve):
  // the partition is a fixed point of bisections, and the same demand sets recur.
  std::map<std::vector<std::uintptr_t>, std::vector<double>> targets_memo_;
  std::vector<std::uintptr_t> key_;  // scratch
};

}  // namespace rosguard::sim

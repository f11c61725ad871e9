// The memory model: how fast each core progresses given what every core runs.
//
// Per cluster a shared L3, and one DRAM behind all clusters. A resource at utilisation u (its
// traffic over its bandwidth) answers with latency(u) = latency_ns + queue_ns * u / (1 - u).
// A core running phase P with L3 hit ratio h retires instructions at
//     CPI = 1 / base_ipc + refill_pki / 1000 * f * max(0, L - L3_unloaded) / n
//     L   = l3_latency(cluster) + (1 - h) * dram_latency,   n = min(mlp, mshr.per_core) * s
// (with a system-level cache, below, dram_latency is the L3 miss's mix of SLC and DRAM latency)
// (f in cycles per ns), and moves (refill_pki + wb_pki) / 1000 L3 lines per instruction, of which
// the fraction (1 - h) also goes to DRAM. The DRAM's utilisation counts a write-back as
// dram.writeback_weight of a refill (1 by default: a line each way; rosguard calibrate fits it).
//
// Memory-level parallelism as a limit: a core has at most n L2 refills in flight (its phase's
// mlp, cut at the platform's mshr.per_core); the cores of a cluster together at most
// mshr.per_cluster L3 misses in flight to the DRAM. By Little's law a core with X L2 refills per
// ns, (1 - h) of them L3 misses taking dram_latency, keeps X (1 - h) dram_latency of them in
// flight; where the cluster's sum exceeds its bound, every core's n is scaled by one s < 1 so that
// it fits (s = 1 otherwise), which lowers X until it does. With the latencies' queueing this is a
// closed loop: more traffic, longer latencies, fewer misses completed per ns.
//
// The shared L3 (model/cache/shared_lru.h): every phase has a miss-ratio curve m(c) of its L2
// refills vs the L3 share c it holds (workload/profile.h). The resident cores of a cluster
// share it as LRU does, by the natural partition (equal eviction age, the footprint / HOTL
// model): each holds its footprint at the common age, growing at its insertion rate, so a
// streaming co-runner takes most of the cache and a light one keeps what its reuse earns. The
// access rates of the partition are the cores' L2 refills per ns at the unloaded latencies
// with the hit ratios of the partition (a fixed point, iterated); h = 1 - m(c). These
// occupancies are the steady state; the simulator moves each core's occupancy towards it over
// time (residency.h: refill after throttling) and solves with the hit ratios of the
// occupancies (solve(demands, hits)).
//
// The system-level cache (optional, platform "memory.slc"): one more shared LRU level below every
// cluster's L3, fed by their misses. A core with L3 hit ratio h sends it the accesses its curve
// misses at c3 = m.capacity_for(1 - h) (its share that gives h: lines its L3 holds without reuse,
// a cyclic stream larger than its share, count for nothing), so its curve there is
// m(c3 + x) / m(c3) (MissRatioCurve::beyond); the running cores of all clusters share it by the
// natural partition, with accesses their L3 misses per ns at the unloaded latencies (a fixed
// point, iterated as for the L3). A core with SLC hit ratio g then waits, per L3 miss,
//     g * slc.latency_ns + (1 - g) * dram_latency
// instead of dram_latency, and sends (1 - g) of its L3 misses (and all its L3 write-backs) to the
// DRAM. The SLC has no bandwidth or queue of its own and no refill dynamics (its occupancies are
// the steady state of the cores running now). Without it g = 0 and all of the above is as before.
//
// The latencies are the fixed point of "latency -> rates -> traffic -> utilisation -> latency"
// (utilisation is monotone in it, so the root is unique): solved by nested bracketed root finding
// on the utilisations (DRAM outside, each cluster's L3 inside). Deterministic: the same demands
// give the same doubles, independent of any earlier solve.
//
// Contract: pure C++, no state besides the parameters; safe to share.
#pragma once

#include <span>
#include <vector>

#include "platform/sim_platform.h"
#include "workload/profile.h"

namespace rosguard::sim {

// What one core asks of the memory system now.
struct CoreDemand {
  int cluster = 0;
  const Phase* phase = nullptr;    // the phase it is running; null: no traffic (idle, callback)
  const void* workload = nullptr;  // whose lines it holds in the L3 (its profile); null: none
  bool resident = false;  // it claims its L3 share (running, or briefly preempted); else its
                          // lines age out of the L3
  const Phase* resident_phase = nullptr;  // the phase it runs or will resume (its curve, rate)
};

// The memory system's answer: latencies, utilisations, hit ratios and miss-in-flight scales.
struct MemoryState {
  std::vector<double> l3_ns;      // per cluster
  std::vector<double> l3_util;    // per cluster
  std::vector<double> mlp_scale;  // per cluster: s in (0, 1], 1 unless mshr.per_cluster binds
  std::vector<double> l3_hit;     // per demand (in the order solve() got them), in [0, 1]
  std::vector<double> slc_hit;    // per demand: the SLC hit ratio of its L3 misses (0: no SLC)
  double dram_ns = 0.0;
  double dram_util = 0.0;
  bool operator==(const MemoryState&) const = default;
};

// Progress and traffic of one core, per ns.
struct CoreRates {
  double inst_per_ns = 0.0;
  double refill_per_ns = 0.0;      // L2 refills (L3 reads)
  double wb_per_ns = 0.0;          // L2 write-backs (L3 writes)
  double l3_refill_per_ns = 0.0;   // L2 refills that miss in the L3 (DRAM reads)
  double dram_lines_per_ns = 0.0;  // lines read from and written to DRAM
  double dram_wb_per_ns = 0.0;     // of those, write-backs
};

class ContentionModel {
 public:
  explicit ContentionModel(const SimPlatform& platform);

  // The unloaded state for `demands` cores (every hit ratio 1, no scale).
  MemoryState unloaded(std::size_t demands = 0) const;
  // With the steady-state hit ratios (steady_hits()).
  MemoryState solve(std::span<const CoreDemand> demands) const;
  // With each demand's L3 hit ratio given (residency.h: refill after throttling).
  MemoryState solve(std::span<const CoreDemand> demands, std::span<const double> hits) const;
  // Rates of a core running `phase` on `cluster` with L3 hit ratio `hit` and `slc_hit` of its
  // L3 misses hitting in the system-level cache (state.slc_hit; 0 without one).
  CoreRates rates(const Phase& phase, double hit, int cluster, const MemoryState& state,
                  double slc_hit = 0.0) const;
  // Instructions per ns of a core running `phase` on `cluster` with every other core idle: its
  // progress in isolation (it holds the whole L3, or all it reuses).
  double alone_inst_per_ns(const Phase& phase, int cluster) const;
  // The steady-state L3 occupancy (KB) of each demand: the natural partition of each cluster's
  // L3 among its resident demands; 0 for a demand that is not resident.
  std::vector<double> occupancies(std::span<const CoreDemand> demands) const;
  // The hit ratio of each demand's phase (running, else resident) at its steady occupancy;
  // 1 for a demand with neither.
  std::vector<double> steady_hits(std::span<const CoreDemand> demands) const;

  // The SLC hit ratio of each demand's L3 misses with these L3 hit ratios: the natural partition
  // of the system-level cache among the running demands; all 0 without one.
  std::vector<double> slc_hits(std::span<const CoreDemand> demands,
                               std::span<const double> hits) const;

  // latency(u) of the L3 or the DRAM; u is clamped below 1.
  double l3_latency(double u) const;
  double dram_latency(double u) const;
  // The latency an L3 miss of a core with SLC hit ratio g waits: g * slc.latency_ns +
  // (1 - g) * dram_ns, or dram_ns without an SLC.
  double miss_latency(double g, double dram_ns) const;
  double line_kb() const { return line_ / 1024.0; }

  // Bytes per ns of a bandwidth in MB/s (MiB/s, Eq. 1).
  static double bytes_per_ns(double mbps) { return mbps * 1048576.0 / 1e9; }

 private:
  // rates() with the cluster's L3 latency, the DRAM latency and the cluster's scale of misses in
  // flight given directly (the inner loops of solve(), without a MemoryState).
  CoreRates rates_at(const Phase& phase, double hit, double l3_ns, double dram_ns, double scale,
                     double slc_hit) const;
  // The cluster's scale s of misses in flight at these latencies (1 when mshr.per_cluster holds).
  double cluster_scale(std::span<const CoreDemand> demands, std::span<const double> hits,
                       std::span<const double> slc, int cluster, double l3_ns,
                       double dram_ns) const;
  double l3_traffic(std::span<const CoreDemand> demands, std::span<const double> hits,
                    std::span<const double> slc, int cluster, double l3_ns, double dram_ns,
                    double* dram_bytes, double* scale) const;

  SimPlatform p_;
  double f_ghz_;
  double line_;
};

}  // namespace rosguard::sim

// The memory model: how fast each core progresses given what every core runs.
//
// Per cluster a shared L3, and one DRAM behind all clusters. A resource at utilisation u (its
// traffic over its bandwidth) answers with latency(u) = latency_ns + queue_ns * u / (1 - u).
// A core running phase P retires instructions at
//     CPI = 1 / base_ipc + refill_pki / 1000 * f * max(0, L - L3_unloaded) / mlp
//     L   = l3_latency(cluster) + (1 - h) * dram_latency,   h = l3_hit * capacity_factor(cluster)
// (f in cycles per ns), and moves (refill_pki + wb_pki) / 1000 L3 lines per instruction, of which
// the fraction (1 - h) also goes to DRAM.
//
// Capacity contention: when the footprints resident in a cluster do not fit in its L3 (C), the
// cores share it as an LRU cache does, in proportion to how fast they insert lines: each resident
// core gets a share of C proportional to its pressure (its L3 access rate at the unloaded
// latency), capped at its footprint, the rest going to the others (water-filling). A core holding
// share S of its footprint F sees capacity_factor = min(1, S / F)^capacity_exponent. So a
// streaming co-runner evicts a light one, while a light co-runner barely disturbs a stream.
// These shares are the steady state; the simulator moves each core's residency towards its
// share over time (residency.h: refill after throttling) and solves with the capacity factors
// of the residencies (solve(demands, capf)).
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
  const Phase* phase = nullptr;  // the phase it is running; null: no traffic (idle, callback)
  double l3_hit = 1.0;
  double footprint_kb = 0.0;
  bool resident = false;  // it claims its L3 share (running, or briefly preempted); else its
                          // lines (footprint_kb, when known) age out of the L3
  const Phase* resident_phase = nullptr;  // the phase it runs or will resume (its L3 pressure)
};

// The memory system's answer: latencies, utilisations and capacity factors.
struct MemoryState {
  std::vector<double> l3_ns;            // per cluster
  std::vector<double> l3_util;          // per cluster
  std::vector<double> capacity_factor;  // per demand (in the order solve() got them), in (0, 1]
  double dram_ns = 0.0;
  double dram_util = 0.0;
  bool operator==(const MemoryState&) const = default;
};

// Progress and traffic of one core, per ns.
struct CoreRates {
  double inst_per_ns = 0.0;
  double refill_per_ns = 0.0;     // L2 refills (L3 reads)
  double wb_per_ns = 0.0;         // L2 write-backs (L3 writes)
  double l3_refill_per_ns = 0.0;  // L2 refills that miss in the L3 (DRAM reads)
  double dram_lines_per_ns = 0.0;
};

class ContentionModel {
 public:
  explicit ContentionModel(const SimPlatform& platform);

  // The unloaded state for `demands` cores (every capacity factor 1).
  MemoryState unloaded(std::size_t demands = 0) const;
  MemoryState solve(std::span<const CoreDemand> demands) const;
  // The same with each demand's capacity factor given (residency.h: refill after throttling).
  MemoryState solve(std::span<const CoreDemand> demands, std::span<const double> capf) const;
  // Rates of a core running `phase` with its L3 hit ratio scaled by `capacity_factor`.
  CoreRates rates(const Phase& phase, double l3_hit, int cluster, double capacity_factor,
                  const MemoryState& state) const;
  // Instructions per ns of a core running `phase` of a workload (l3_hit, footprint_kb) on
  // `cluster` with every other core idle: its progress in isolation.
  double alone_inst_per_ns(const Phase& phase, double l3_hit, double footprint_kb,
                           int cluster) const;
  // L3 shares in KB: the footprint where the resident footprints of a cluster fit, else the
  // water-filling share; 0 for a demand that is not resident.
  std::vector<double> shares(std::span<const CoreDemand> demands) const;
  // L3 shares as capacity factors: min(1, share / footprint)^capacity_exponent (1 where the
  // resident footprints fit, and for demands that are not resident).
  std::vector<double> capacity_factors(std::span<const CoreDemand> demands) const;

  // latency(u) of the L3 or the DRAM; u is clamped below 1.
  double l3_latency(double u) const;
  double dram_latency(double u) const;

  // Bytes per ns of a bandwidth in MB/s (MiB/s, Eq. 1).
  static double bytes_per_ns(double mbps) { return mbps * 1048576.0 / 1e9; }

 private:
  double l3_traffic(std::span<const CoreDemand> demands, const std::vector<double>& capf,
                    int cluster, double l3_ns, double dram_ns, double* dram_bytes) const;

  SimPlatform p_;
  double f_ghz_;
  double line_;
};

}  // namespace rosguard::sim

// Seeded draws from the platform's cost distributions (pmc_callback_us, message_latency_us, ...).
//
// Contract: pure C++, deterministic: the same distribution and seed give the same sequence on
// every run (std::mt19937_64 is specified bit for bit; the transforms are written out here rather
// than left to a standard library's distribution classes). One CostStream per (node, cost), so
// that one node drawing more often does not shift another node's draws. Not thread-safe.
#pragma once

#include <cstdint>
#include <random>
#include <string_view>

#include "core/types.h"
#include "platform/sim_platform.h"

namespace rosguard::sim {

// Seed of a named stream within a run: mixes the run's seed with the stream name.
std::uint64_t stream_seed(std::uint64_t run_seed, std::string_view stream);

class CostStream {
 public:
  CostStream(const Distribution& dist, std::uint64_t seed) : dist_(dist), rng_(seed) {}

  double draw_us();
  // Rounded to whole nanoseconds, at least 1 ns (a cost of zero would reorder events).
  TimeNs draw_ns();

 private:
  double uniform01();  // in [0, 1)
  double normal01();   // standard normal (Box-Muller)

  Distribution dist_;
  std::mt19937_64 rng_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace rosguard::sim

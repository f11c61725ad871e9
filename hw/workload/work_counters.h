// Progress counters a built-in workload publishes while it runs.
//
// Contract: written only by the thread that runs the workload (the NCT or RT thread), with
// relaxed stores of monotonically increasing values; read from any thread (the PMC callback, the
// controller, the engine) with relaxed loads. The instrumented PMC source turns them into
// counter values; the engine uses units_done for fractional runs.
#pragma once

#include <atomic>
#include <cstdint>

namespace rosguard::hw {

struct WorkCounters {
  alignas(64) std::atomic<std::uint64_t> lines_read{0};  // cache lines loaded
  std::atomic<std::uint64_t> lines_written{0};           // cache lines stored to
  std::atomic<std::uint64_t> units_done{0};              // work units retired (all runs)

  // Single writer: a plain load + store is enough and avoids a locked instruction per update.
  static void add(std::atomic<std::uint64_t>& c, std::uint64_t n) {
    c.store(c.load(std::memory_order_relaxed) + n, std::memory_order_relaxed);
  }
};

}  // namespace rosguard::hw

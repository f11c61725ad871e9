// Progress counters a built-in workload publishes while it runs.
//
// Contract: written only by the thread that runs the workload (the NCT or RT thread), with
// relaxed stores of monotonically increasing values; read from any thread (the PMC callback, the
// controller, the engine) with relaxed loads. The instrumented PMC source turns them into
// counter values; the engine uses units_done for fractional runs.
//
// Overflow watches (the instrumented source's overflow counters, hw/pmc_source/overflow.h): a
// watch fires when its count (kRefillWatch: lines read + written; kWbWatch: lines written)
// reaches `at`. The workload thread checks its watches after each chunk it retires; one that
// fired queues signal `sig` with `slot` as its value to thread `tid` (rt_tgsigqueueinfo), as a
// PMU raises its overflow interrupt, and moves `at` one period on. The owner sets tid, sig and
// slot once, then arms with period, at, then its bit in `watching` (release); at = kNever and
// the bit cleared disarm.
#pragma once

#include <sys/types.h>

#include <array>
#include <atomic>
#include <cstdint>

namespace rosguard::hw {

struct OverflowWatch {
  static constexpr std::uint64_t kNever = ~std::uint64_t{0};
  std::atomic<std::uint64_t> at{kNever};
  std::atomic<std::uint64_t> period{0};
  std::atomic<pid_t> tid{0};
  std::atomic<int> sig{0};
  std::atomic<int> slot{-1};
};

struct WorkCounters {
  static constexpr std::size_t kRefillWatch = 0, kWbWatch = 1;
  // The built-in kernels retire their lines (publish them, check the watches and their stop
  // flag) in chunks of at most this many.
  static constexpr std::uint64_t kChunkLines = 64;

  alignas(64) std::atomic<std::uint64_t> lines_read{0};  // cache lines loaded
  std::atomic<std::uint64_t> lines_written{0};           // cache lines stored to
  std::atomic<std::uint64_t> units_done{0};              // work units retired (all runs)

  // What watch i counts.
  std::uint64_t watched(std::size_t i) const noexcept {
    const std::uint64_t w = lines_written.load(std::memory_order_relaxed);
    return i == kRefillWatch ? lines_read.load(std::memory_order_relaxed) + w : w;
  }

  // Control state, not counts: armed by the owner of an overflow counter through a const view.
  mutable std::array<OverflowWatch, 2> watches;
  mutable std::atomic<std::uint32_t> watching{0};  // bit i: watch i armed

  // The workload thread: fires every armed watch whose count reached its `at`.
  void check_watches() noexcept;
};

// The workload thread's side of one run: keeps the counts it publishes in registers, so a chunk
// costs a store per count (single writer: no locked instruction) and one load for the watches.
class CountWriter {
 public:
  // `lines`: lines_read or lines_written of `c`, the count this run's lines go to.
  CountWriter(WorkCounters& c, std::atomic<std::uint64_t>& lines)
      : c_(c),
        lines_(lines),
        n_lines_(lines.load(std::memory_order_relaxed)),
        n_units_(c.units_done.load(std::memory_order_relaxed)) {}

  // After a chunk: n lines (and n units) retired, then the overflow watches.
  void retire(std::uint64_t n) noexcept {
    lines_.store(n_lines_ += n, std::memory_order_relaxed);
    c_.units_done.store(n_units_ += n, std::memory_order_relaxed);
    if (c_.watching.load(std::memory_order_acquire) != 0) c_.check_watches();
  }

 private:
  WorkCounters& c_;
  std::atomic<std::uint64_t>& lines_;
  std::uint64_t n_lines_, n_units_;
};

}  // namespace rosguard::hw

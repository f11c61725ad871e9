// The regulation metric: bytes moved, from cumulative PMU counter readings.
//
// Contract: pure functions of their arguments; safe to call from any thread. Counter readings
// are cumulative and carry perf's time-enabled / time-running so that multiplexed counters are
// scaled (a regulator fed raw multiplexed values under-counts and under-throttles).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace rosguard {

// One cumulative counter reading, as perf_event read() returns it (or as a simulated PMU does).
struct CounterValue {
  std::uint64_t value = 0;
  std::uint64_t time_enabled_ns = 0;
  std::uint64_t time_running_ns = 0;
};

struct MetricEvent {
  std::string name;  // a PMU event name, e.g. "l2d_cache_refill"
  double weight = 1.0;
};

// bytes = line_bytes * sum_i(weight_i * delta(event_i)). Default: L3 accesses on the Orin
// (L2 refills + L2 write-backs) times 64-byte lines.
struct MetricSpec {
  std::uint32_t line_bytes = 64;
  std::vector<MetricEvent> events = {{"l2d_cache_refill", 1.0}, {"l2d_cache_wb", 1.0}};
  // Width of the hardware counters; values wrap modulo 2^counter_bits (perf gives 64 bits,
  // a raw ARMv8 PMU event counter is 32 bits).
  unsigned counter_bits = 64;
};

// Increase of a counter from `prev` to `cur`, modulo 2^bits (one wrap at most between reads).
std::uint64_t wrap_delta(std::uint64_t prev, std::uint64_t cur, unsigned bits);

// Increase of a counter between two readings, scaled for multiplexing: the raw increase times
// (enabled increase / running increase). A counter that did not run at all in between gives its
// raw increase (zero on a real PMU) rather than a guess.
double scaled_delta(const CounterValue& prev, const CounterValue& cur, unsigned bits);

class Metric {
 public:
  explicit Metric(MetricSpec spec);

  const MetricSpec& spec() const { return spec_; }
  std::size_t event_count() const { return spec_.events.size(); }

  // Bytes moved between two readings of the same event group (same order as spec().events).
  double delta_bytes(std::span<const CounterValue> prev, std::span<const CounterValue> cur) const;
  // The same per event: out[i] = line_bytes x weight_i x delta_i; returns their sum.
  double event_bytes(std::span<const CounterValue> prev, std::span<const CounterValue> cur,
                     std::span<double> out) const;

 private:
  MetricSpec spec_;
};

// Eq. 1 of the paper: bw [MB/s] = 64 * freq * l3_accesses / (cycles * 1024 * 1024), written for
// any line size. Returns 0 when no cycle elapsed.
double eq1_mbps(double line_bytes, double freq_hz, double l3_accesses, double cycles);

// Bytes allowed in `length_ns` at `pct` percent of `reference_mbps` (MB/s of Eq. 1).
double budget_bytes(double pct, double reference_mbps, std::int64_t length_ns);

}  // namespace rosguard

#include "metric/metric.h"

#include <stdexcept>

#include "core/error.h"
#include "core/types.h"

namespace rosguard {

std::uint64_t wrap_delta(std::uint64_t prev, std::uint64_t cur, unsigned bits) {
  if (bits >= 64) return cur - prev;  // unsigned arithmetic wraps modulo 2^64
  const std::uint64_t mask = (std::uint64_t{1} << bits) - 1;
  return (cur - prev) & mask;
}

double scaled_delta(const CounterValue& prev, const CounterValue& cur, unsigned bits) {
  const auto raw = static_cast<double>(wrap_delta(prev.value, cur.value, bits));
  const std::uint64_t enabled = cur.time_enabled_ns - prev.time_enabled_ns;
  const std::uint64_t running = cur.time_running_ns - prev.time_running_ns;
  if (running == 0 || running >= enabled) return raw;
  return raw * static_cast<double>(enabled) / static_cast<double>(running);
}

Metric::Metric(MetricSpec spec) : spec_(std::move(spec)) {
  if (spec_.events.empty()) throw ContractError("metric needs at least one event");
  if (spec_.counter_bits == 0 || spec_.counter_bits > 64)
    throw ContractError("counter_bits must be in [1, 64]");
}

double Metric::delta_bytes(std::span<const CounterValue> prev,
                           std::span<const CounterValue> cur) const {
  if (prev.size() != spec_.events.size() || cur.size() != spec_.events.size())
    throw ContractError("counter group size does not match the metric's events");
  double lines = 0.0;
  for (std::size_t i = 0; i < cur.size(); ++i)
    lines += spec_.events[i].weight * scaled_delta(prev[i], cur[i], spec_.counter_bits);
  return lines * spec_.line_bytes;
}

double Metric::event_bytes(std::span<const CounterValue> prev, std::span<const CounterValue> cur,
                           std::span<double> out) const {
  if (prev.size() != spec_.events.size() || cur.size() != spec_.events.size() ||
      out.size() != spec_.events.size())
    throw ContractError("counter group size does not match the metric's events");
  double sum = 0.0;
  for (std::size_t i = 0; i < cur.size(); ++i) {
    out[i] = spec_.events[i].weight * scaled_delta(prev[i], cur[i], spec_.counter_bits) *
             spec_.line_bytes;
    sum += out[i];
  }
  return sum;
}

double eq1_mbps(double line_bytes, double freq_hz, double l3_accesses, double cycles) {
  if (cycles <= 0.0) return 0.0;
  return line_bytes * freq_hz * l3_accesses / (cycles * kBytesPerMb);
}

double budget_bytes(double pct, double reference_mbps, std::int64_t length_ns) {
  return pct / 100.0 * reference_mbps * kBytesPerMb * static_cast<double>(length_ns) /
         static_cast<double>(kNsPerS);
}

}  // namespace rosguard

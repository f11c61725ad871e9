#include "engine/outcome.h"

#include <limits>

#include "metric/metric.h"

namespace rosguard {

double not_applicable() {
  return std::numeric_limits<double>::quiet_NaN();
}

RtOutcome rt_outcome(const std::string& name, std::span<const double> job_ns,
                     std::span<const double> response_ns, std::optional<double> period_ns) {
  RtOutcome o;
  o.name = name;
  double sum = 0.0;
  for (double j : job_ns)
    sum += j;
  o.jobs = static_cast<int>(job_ns.size());
  o.time_us = o.jobs ? sum / o.jobs / 1e3 : not_applicable();
  if (period_ns) o.deadline_misses = 0;
  for (double r : response_ns) {
    o.response_us.push_back(r / 1e3);
    if (period_ns && r > *period_ns) ++o.deadline_misses;
  }
  return o;
}

namespace {

double bandwidth_mbps(const NrtMeasure& m) {
  if (m.traffic.cycles > 0.0) return eq1_mbps(1.0, m.freq_hz, m.traffic.bytes, m.traffic.cycles);
  if (m.traffic_ns > 0)
    return m.traffic.bytes / kBytesPerMb / (static_cast<double>(m.traffic_ns) / 1e9);
  return not_applicable();
}

}  // namespace

NrtOutcome nrt_outcome(const NrtMeasure& m, const NrtDriver& driver) {
  NrtOutcome o;
  o.name = m.name;
  o.runs = m.runs;
  if (m.once)
    o.time_us = m.once_ns ? *m.once_ns / 1e3 : not_applicable();
  else
    o.time_us = m.runs > 0 && m.window_ns > 0 ? static_cast<double>(m.window_ns) / m.runs / 1e3
                                              : not_applicable();
  o.bandwidth_mbps = bandwidth_mbps(m);
  o.throttle_count = driver.throttles();
  o.throttled_us = static_cast<double>(driver.throttled_ns()) / 1e3;
  return o;
}

}  // namespace rosguard

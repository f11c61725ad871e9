#include "engine/outcome.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"
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

double IsolationProgress::runs_at(double w) const {
  const double per_run = work_per_run();
  if (per_run <= 0.0 || work.size() != time.size() || time.back() <= 0.0)
    throw ContractError("an isolation progress needs work and time that end in one whole run");
  const double whole = std::floor(w / per_run);
  const double rest = w - whole * per_run;
  // The piece of the run `rest` lies in, and the linear share of it.
  const auto k =
      static_cast<std::size_t>(std::upper_bound(work.begin(), work.end(), rest) - work.begin());
  if (k >= work.size()) return whole + 1.0;
  const double w0 = k ? work[k - 1] : 0.0, t0 = k ? time[k - 1] : 0.0;
  const double t = t0 + (time[k] - t0) * (rest - w0) / (work[k] - w0);
  return whole + t / time.back();
}

double IsolationProgress::isolation_runs(double from, double to) const {
  if (to < from) throw ContractError("isolation_runs: a work range that ends before it starts");
  return runs_at(to) - runs_at(from);
}

NrtOutcome nrt_outcome(const NrtMeasure& m, const NrtDriver& driver) {
  NrtOutcome o;
  o.name = m.name;
  if (m.once) {
    o.runs = m.runs;
    o.time_us = m.once_ns ? *m.once_ns / 1e3 : not_applicable();
  } else {
    o.runs = (m.work_to - m.work_from) / m.progress.work_per_run();
    const double iso_runs = m.progress.isolation_runs(m.work_from, m.work_to);
    o.time_us = iso_runs > 0 && m.window_ns > 0 ? static_cast<double>(m.window_ns) / iso_runs / 1e3
                                                : not_applicable();
  }
  o.bandwidth_mbps = bandwidth_mbps(m);
  o.throttle_count = driver.throttles();
  o.throttled_us = static_cast<double>(driver.throttled_ns()) / 1e3;
  return o;
}

}  // namespace rosguard

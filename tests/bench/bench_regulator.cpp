// Cost of the regulator core per sample. The paper's ROS2 PMC callback costs about 15 us; the
// core must be a negligible part of any sampling loop (target: median <= 100 ns per sample with
// 12 regulated cores).
#include <benchmark/benchmark.h>

#include <array>
#include <vector>

#include "metric/metric.h"
#include "policy/policy.h"
#include "regulator/regulator.h"

namespace {

using namespace rosguard;

// Interval regulation of `entities` cores sampled round robin, each every 1 ms, 5 ms periods.
// Every core reads about 30 % of the reference bandwidth, so with a 20 % threshold throttles and
// replenishes happen all the time, as in a saturated co-run.
void BM_RegulatorSample(benchmark::State& state) {
  const auto entities = static_cast<std::size_t>(state.range(0));
  PolicyParams params;
  params.threshold_pct = 20.0;
  params.reference_mbps = 26271.74;
  params.regulation_period_ns = 5 * kNsPerMs;
  RegulatorConfig config{1, accounts_for_scope(Scope::Core, entities), MetricSpec{}};
  Regulator reg(config, make_interval_policy(params));
  Commands out;
  out.reserve(64);
  reg.rt_started(0, 0, out);

  const TimeNs period = kNsPerMs / static_cast<TimeNs>(entities);
  const auto lines_per_sample =
      static_cast<std::uint64_t>(26271.74 * 0.30 * 1024 * 1024 / 1000 / 64);
  std::vector<std::array<CounterValue, 2>> counters(entities);
  TimeNs t = 0;
  std::size_t e = 0;
  std::uint64_t commands = 0;
  for (auto _ : state) {
    t += period;
    auto& c = counters[e];
    c[0].value += lines_per_sample;
    c[1].value += lines_per_sample / 4;
    for (auto& v : c) {
      v.time_enabled_ns = static_cast<std::uint64_t>(t);
      v.time_running_ns = static_cast<std::uint64_t>(t);
    }
    reg.sample(t, e, c, out);
    commands += out.size();
    out.clear();
    e = e + 1 == entities ? 0 : e + 1;
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["commands_per_sample"] =
      benchmark::Counter(static_cast<double>(commands) / static_cast<double>(state.iterations()));
}
BENCHMARK(BM_RegulatorSample)->Arg(1)->Arg(12);

// The metric alone: wrap- and multiplex-aware delta of a 2-event group.
void BM_MetricDelta(benchmark::State& state) {
  Metric metric(MetricSpec{});
  std::array<CounterValue, 2> prev{}, cur{};
  for (auto _ : state) {
    cur[0].value += 1000;
    cur[1].value += 250;
    cur[0].time_enabled_ns = cur[1].time_enabled_ns += 1000;
    cur[0].time_running_ns = cur[1].time_running_ns += 500;
    benchmark::DoNotOptimize(metric.delta_bytes(prev, cur));
    prev = cur;
  }
}
BENCHMARK(BM_MetricDelta);

}  // namespace

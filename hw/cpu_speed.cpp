#include "hw/cpu_speed.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "hw/common/clock.h"
#include "hw/workload/workload.h"
#include "results/results.h"

namespace rosguard::hw {
namespace {

// The kernel touches one 64-byte line per work unit (hw/workload/kernels.cpp).
constexpr double kBytesPerUnit = 64.0;

std::unique_ptr<BuiltinWorkload> reference_kernel(int working_set_kb, std::uint64_t passes) {
  const nlohmann::json doc{
      {"name", "bandwidth_read"},
      {"hw",
       {{"kernel", "bandwidth_read"}, {"working_set_kb", working_set_kb}, {"passes", passes}}}};
  return make_builtin_workload(WorkloadInfo{"bandwidth_read", "rosguard cpu speed probe", doc});
}

// Runs `body` on a thread pinned to `cpu`; returns whether it was pinned there.
bool on_cpu(int cpu, SchedClass sched, const std::function<void()>& body) {
  RtThread t(ThreadSpec{"rg-cpu-speed", cpu, sched, prio::kNct}, body);
  t.join();
  if (t.error()) std::rethrow_exception(t.error());
  return t.outcome().pinned;
}

}  // namespace

CpuSpeedReport time_cpus(const std::vector<int>& cpus, SchedClass sched,
                         const CpuSpeedOptions& options) {
  CpuSpeedReport report;
  report.options = options;
  if (cpus.empty()) return report;
  const std::atomic<bool> stop{false};
  WorkCounters counters;
  // One pass warms a CPU's caches with the working set; the passes of a window are sized from
  // the fastest pass of a 20 ms warm-up on the first CPU (a preempted pass would size it long).
  auto one_pass = reference_kernel(options.working_set_kb, 1);
  double fastest_ns = std::numeric_limits<double>::infinity();
  on_cpu(cpus.front(), sched, [&] {
    const TimeNs until = now_ns() + 20 * kNsPerMs;
    do {
      const TimeNs t0 = now_ns();
      one_pass->run(stop, counters);
      fastest_ns = std::min(fastest_ns, static_cast<double>(now_ns() - t0));
    } while (now_ns() < until);
  });
  report.passes = static_cast<std::uint64_t>(
      std::max(1.0, options.window_ms * 1e6 / std::max(fastest_ns, 1.0)));
  auto window = reference_kernel(options.working_set_kb, report.passes);
  const double bytes = static_cast<double>(window->units_per_run()) * kBytesPerUnit;
  for (int c : cpus)
    report.cpus.push_back(CpuSpeed{c, true, {}, 0.0, 0.0});
  // Windows interleaved over the CPUs, so that a change of the host's load hits them alike.
  for (int w = 0; w < options.windows; ++w)
    for (auto& cpu : report.cpus) {
      double s = 0.0;
      cpu.pinned = on_cpu(cpu.cpu, sched,
                          [&] {
                            one_pass->run(stop, counters);
                            const TimeNs t0 = now_ns();
                            window->run(stop, counters);
                            s = static_cast<double>(now_ns() - t0) / 1e9;
                          }) &&
                   cpu.pinned;
      cpu.windows_mbps.push_back(s > 0.0 ? bytes / s / kBytesPerMb
                                         : std::numeric_limits<double>::quiet_NaN());
    }
  for (auto& cpu : report.cpus) {
    cpu.mbps = median(cpu.windows_mbps);
    cpu.cv = coefficient_of_variation(cpu.windows_mbps);
  }
  return report;
}

std::vector<CpuSpeed> slow_cpus(const std::vector<CpuSpeed>& cpus, double margin) {
  double fastest = 0.0;
  for (const auto& c : cpus)
    if (std::isfinite(c.mbps)) fastest = std::max(fastest, c.mbps);
  std::vector<CpuSpeed> out;
  for (const auto& c : cpus)
    if (std::isfinite(c.mbps) && c.mbps < (1.0 - margin) * fastest) out.push_back(c);
  std::sort(out.begin(), out.end(),
            [](const CpuSpeed& a, const CpuSpeed& b) { return a.mbps < b.mbps; });
  return out;
}

}  // namespace rosguard::hw

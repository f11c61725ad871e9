// A memory-bound piece of work a node's callback can run and ROSGuard can count without a
// hardware PMU: one of rosguard's built-in kernels (bandwidth_read, bandwidth_write, latency,
// ...; docs/workloads.md) on the calling thread, publishing the cache lines it touches into
// WorkCounters (the instrumented PMC source reads them, as in rosguard's hw backend).
//
// Contract: run() is called from one thread at a time (the node's nominal callback); counters()
// may be read from any thread.
#pragma once

#include <rosguard/hw/workload/work_counters.h>
#include <rosguard/hw/workload/workload.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

namespace rosguard_rclcpp {

class Workload {
 public:
  // Throws std::invalid_argument (rosguard's InputError) naming the kernel when it cannot run.
  Workload(const std::string& kernel, std::uint32_t working_set_kb, int passes = 1);
  // One run of the kernel; returns how long it took (s).
  double run();
  // Asks a run() in progress to return early (from another thread).
  void stop() { stop_.store(true, std::memory_order_release); }
  const rosguard::hw::WorkCounters& counters() const { return counters_; }
  // Cache lines of one run (the work units the counters count).
  std::uint64_t lines_per_run() const { return kernel_->units_per_run(); }

 private:
  std::unique_ptr<rosguard::hw::BuiltinWorkload> kernel_;
  rosguard::hw::WorkCounters counters_;
  std::atomic<bool> stop_{false};
};

}  // namespace rosguard_rclcpp

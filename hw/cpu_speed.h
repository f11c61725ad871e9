// How fast each measured CPU runs one reference kernel alone, timed just before an hw run: a
// virtual machine's vCPUs are not equal (up to 3x apart on a 16-vCPU cloud VM, each steady
// within a few percent), and a node on a slow vCPU makes every figure of that node look like
// contention. The runner reports CPUs slower than the fastest by more than a margin.
//
// Contract: time_cpus() is called from the engine's thread with no node running; it starts one
// pinned thread at a time (joined before it returns) and takes about windows x CPUs x
// (window + a few ms). slow_cpus() is pure.
#pragma once

#include <string>
#include <vector>

#include "hw/executor/executor.h"

namespace rosguard::hw {

struct CpuSpeedOptions {
  int windows = 5;          // timed windows per CPU, interleaved over the CPUs
  double window_ms = 10.0;  // length of one window (sized from a warm-up on the first CPU)
  int working_set_kb = 2048;
};

struct CpuSpeed {
  int cpu = 0;
  bool pinned = true;                // false: the probe could not be pinned there
  std::vector<double> windows_mbps;  // bandwidth_read MiB/s of each window
  double mbps = 0.0;                 // their median
  double cv = 0.0;                   // their coefficient of variation (NaN with one)
};

struct CpuSpeedReport {
  CpuSpeedOptions options;
  std::uint64_t passes = 0;  // passes over the working set per window
  std::vector<CpuSpeed> cpus;
};

// bandwidth_read over `working_set_kb` alone on each of `cpus` (sched: the scenario's class at
// the NCT priority, as an isolation run).
CpuSpeedReport time_cpus(const std::vector<int>& cpus, SchedClass sched,
                         const CpuSpeedOptions& options = {});

// The CPUs whose median is below (1 - margin) x the fastest one's, slowest first.
std::vector<CpuSpeed> slow_cpus(const std::vector<CpuSpeed>& cpus, double margin);

// The default margin: each CPU times steadily within about 3 % (16-vCPU VM, 15 runs per CPU),
// so 10 % is a real difference, not noise.
inline constexpr double kSlowCpuMargin = 0.10;

}  // namespace rosguard::hw

// The calibration microbenchmark suite: what `rosguard calibrate` measures on the host with the
// hw backend's own pieces (the built-in kernels, RtThread, Topic / Waker, the PMC source the hw
// backend would pick, the controller engine), as calibration::Measurements for the sim model fit.
//
// Contract:
// - run_suite() is called from one thread (the CLI's main thread); it starts and joins every
//   thread it needs, pinned to `cores`, under SCHED_FIFO where the host allows it (else the
//   executor's SCHED_OTHER fallback, reported in notes). No thread outlives the call.
// - Kernel measurements: every KernelRun is the median ns per 64-byte line of `repetitions`
//   timed windows, each taken while the measured kernel and its co-runners all stream (started,
//   warmed up, measured, stopped). The repetitions of the configurations of one block are
//   interleaved (repetition r of every configuration before repetition r + 1 of any), so drift
//   hits them all alike.
// - `stop` (set by a SIGINT handler) ends the suite between two windows: the result holds what
//   was measured so far and `stopped` is true. progress is called from the calling thread.
// - Throws RunError when a kernel cannot be set up (memory) or the PMC source fails.
#pragma once

#include <atomic>
#include <functional>
#include <string>
#include <vector>

#include "calibration/measurements.h"

namespace rosguard::hw {

// The suite's shape: working sets, repetitions, window lengths, cost sample counts. shape_for()
// derives it from the host; tests pass a tiny one.
struct SuiteShape {
  std::vector<double> isolation_kb;  // isolation sweep of every kernel
  double in_l3_kb = 0.0;             // bandwidth-latency curve: measured working sets
  double dram_kb = 0.0;              // (and the co-runners' DRAM working set)
  double workload_kb = 2048.0;       // the shipped workloads' working set (co-runners, matrix)
  // Co-runner counts of the bandwidth-latency curve (each at most cores - 1); empty: every count
  // 1..cores - 1. The pair matrix always uses one.
  std::vector<int> corunner_counts;
  int repetitions = 5;
  double window_ms = 20.0;         // one timed window
  double warmup_ms = 20.0;         // at most this long waiting for a kernel to stream (one pass)
  int cost_samples = 500;          // per cost
  double cost_spacing_us = 300.0;  // between two cost samples (the callee sleeps in between)
};

struct SuiteOptions {
  calibration::HostFacts host;
  bool quick = false;
  // Cores to use: the first measures, the others run co-runners (and the costs' far ends).
  // Empty: the first host.cores_per_cluster usable CPUs (HostFacts does not say which CPUs
  // share the L3, so this assumes they are numbered cluster by cluster).
  std::vector<int> cores;
  std::function<void(int step, int steps, const std::string& what)> progress;
  const std::atomic<bool>* stop = nullptr;  // SIGINT: stop between windows
  const SuiteShape* shape = nullptr;        // tests: instead of shape_for(host, quick)
  // The topic transport of the message costs (publish, message_latency, local_message_latency):
  // "inproc" (the futex rings) or "dds" (Cyclone DDS as hw.transport dds uses it, on the default
  // domain in a namespace of this process).
  std::string transport = "inproc";
};

struct SuiteResult {
  calibration::Measurements measurements;
  // Fallbacks and decisions the manifest should record (SCHED_FIFO refused, working sets capped,
  // the PMC source chosen, a single core).
  std::vector<std::string> notes;
  bool stopped = false;  // stop was set: measurements are partial
};

// Working sets etc. for this host: isolation from 16 KB doubling up to the DRAM working set
// (4x the L3, at least 16 MB, at most 256 MB, and within a quarter of the available memory across
// the cores); quick: one set in the L2, 2048 KB, one in the L3, one in DRAM, and co-runner counts
// 1, 2, 4, ... and cores - 1 only.
SuiteShape shape_for(const calibration::HostFacts& host, bool quick, int cores);

SuiteResult run_suite(const SuiteOptions& options);

}  // namespace rosguard::hw

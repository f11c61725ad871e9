// The hw backend: real threads, real counters, real throttling, measured.
//
// Contract (model/backend/backend.h): validate() rejects what this host cannot run with an
// InputError naming the file and JSON path; isolation() runs a workload alone on its core once
// (the runner asks for hw.baseline_repetitions measurements and uses their median); run_point()
// wires the controller, RT and nRT nodes of one point, runs it and measures it. Calls come one at a
// time from the runner's main thread (process_per_task() is false). On every exit path (success,
// exception, failed node, stop_requested()) every nRT node is returned to nominal, every thread
// joined and every external command killed before the call returns; an interrupted task throws
// Interrupted.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "backend/backend.h"
#include "hw/metric_plan.h"
#include "hw/pmc_source/pmc_source.h"
#include "policy/policy.h"

namespace rosguard::hw {

struct HwOptions {
  // Fault injection for tests: the controller stops answering this long after its first throttle
  // command (negative: never).
  TimeNs controller_fail_after_ns = -1;
  // How long nRT loop workloads run before the RT nodes start.
  TimeNs warmup_ns = 20 * kNsPerMs;
};

std::unique_ptr<Backend> make_hw_backend(const PolicyRegistry& policies, HwOptions options = {});

}  // namespace rosguard::hw

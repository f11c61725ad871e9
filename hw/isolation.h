// Isolation runs of the hw backend: one workload alone on its core, unregulated, measured (the
// paper's Table 1 quantities), while idle spinners hold the scenario's other cores.
//
// Contract: called from the engine's thread; every thread it starts is joined before it returns
// (also on an exception or a stop request, which throws Interrupted).
#pragma once

#include "backend/backend.h"
#include "hw/executor/executor.h"
#include "hw/metric_plan.h"

namespace rosguard::hw {

SchedClass sched_of(const Scenario& s);

IsolationResult measure_alone(const Scenario& s, const MetricPlan& plan,
                              const PmcSourceRegistry& sources, const WorkloadInfo& w, int core,
                              RunContext& ctx);

}  // namespace rosguard::hw

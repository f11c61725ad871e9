// The real-time safety net of the hw backend: what a task leaves behind under a real-time policy,
// and the scheduler fallbacks it took, reported to the run (never silently).
//
// Contract: called from the engine's thread, before and after a task (isolation or point).
#pragma once

#include <sys/types.h>

#include <set>
#include <vector>

#include "backend/backend.h"
#include "hw/executor/executor.h"

namespace rosguard::hw {

// Threads of this process under a real-time policy now (a task's "before").
std::set<pid_t> realtime_tids();
// How many threads that were not in `before` are under a real-time policy now.
std::size_t left_realtime(const std::set<pid_t>& before);
// Throws RunError naming every thread not in `before` still under a real-time policy half a
// second on (a joined thread may still be exiting).
void check_no_realtime_threads(const std::set<pid_t>& before);
// One stable fallback message per kind of refusal (SCHED_FIFO, nice, affinity).
void report_sched(const std::vector<SchedOutcome>& outcomes, RunContext& ctx);
// The controller shares a core with a node (a host with few CPUs): a fallback entry.
void report_shared_core(const Scenario& s, RunContext& ctx);

}  // namespace rosguard::hw

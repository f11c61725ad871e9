#include "hw/safety_net.h"

#include <chrono>
#include <string>
#include <thread>

#include "core/error.h"
#include "hw/common/sys.h"

namespace rosguard::hw {

// After every task no thread that the task started may remain under a real-time policy (they
// have all been joined by now). Threads that were real-time before the task (e.g. rosguard
// itself started with chrt) are not the task's.
std::set<pid_t> realtime_tids() {
  std::set<pid_t> out;
  for (const auto& t : realtime_threads())
    out.insert(t.tid);
  return out;
}

std::size_t left_realtime(const std::set<pid_t>& before) {
  std::size_t n = 0;
  for (const auto& t : realtime_threads())
    n += before.count(t.tid) ? 0 : 1;
  return n;
}

// pthread_join returns once the kernel clears the joined thread's tid, early in its exit; the
// thread stays listed in /proc/self/task, with its policy, until the exit completes (in the CI
// run of 2026-11-28 the DDS domain's "gc" thread, the last one Cyclone joins, was seen there).
// So a thread counts as left behind only when it is still there after a grace period.
constexpr auto kExitGrace = std::chrono::milliseconds(500);

void check_no_realtime_threads(const std::set<pid_t>& before) {
  const auto deadline = std::chrono::steady_clock::now() + kExitGrace;
  std::string names;
  for (;;) {
    names.clear();
    for (const auto& t : realtime_threads())
      if (!before.count(t.tid))
        names += (names.empty() ? "" : ", ") + t.name + " (" + std::to_string(t.tid) + ")";
    if (names.empty() || std::chrono::steady_clock::now() >= deadline) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  if (!names.empty())
    throw RunError("after the point, thread(s) still under a real-time policy: " + names);
}

// One stable message per kind of refusal (the runner keeps each distinct fallback once).
void report_sched(const std::vector<SchedOutcome>& outcomes, RunContext& ctx) {
  std::set<std::string> fifo, nice, pin, idle;
  for (const auto& o : outcomes) {
    if (!o.fifo) fifo.insert(o.fifo_error);
    if (!o.idle) idle.insert(o.idle_error);
    if (!o.nice_error.empty()) nice.insert(o.nice_error);
    if (!o.pinned) pin.insert(o.pin_error);
  }
  const auto join = [](const std::set<std::string>& v) {
    std::string s;
    for (const auto& x : v)
      s += (s.empty() ? "" : ", ") + x;
    return s;
  };
  if (!fifo.empty())
    ctx.fallback("sched_fifo",
                 "SCHED_FIFO refused (" + join(fifo) +
                     "): the node threads run under SCHED_OTHER with nice values in the same "
                     "priority order; the throttle and the callback priorities are approximate" +
                     (nice.empty() ? std::string()
                                   : "; raising priorities with nice was refused too (" +
                                         join(nice) + "), so they share the CPU at nice 0"));
  if (!idle.empty())
    ctx.fallback("sched_idle", "SCHED_IDLE refused (" + join(idle) +
                                   "): the nRT work runs under SCHED_OTHER and the idle throttle "
                                   "holds it only as far as nice values do");
  if (!pin.empty())
    ctx.fallback("affinity",
                 "a thread could not be pinned to its core (" + join(pin) + "): it runs unpinned");
}

void report_shared_core(const Scenario& s, RunContext& ctx) {
  const int c = s.nodes.controller_core;
  for (const auto& n : s.nodes.rt)
    if (n.core == c)
      ctx.fallback("shared_controller_core",
                   "the controller shares core " + std::to_string(c) + " with RT node '" + n.name +
                       "' (this host has " + std::to_string(usable_cpus().size()) +
                       " usable CPUs): its callbacks preempt the RT node's job");
  for (const auto& n : s.nodes.nrt)
    if (n.core == c)
      ctx.fallback("shared_controller_core",
                   "the controller shares core " + std::to_string(c) + " with nRT node '" + n.name +
                       "' (this host has " + std::to_string(usable_cpus().size()) +
                       " usable CPUs): it preempts the node's throttle when it runs");
}

}  // namespace rosguard::hw

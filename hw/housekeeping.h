// Where rosguard's own threads and processes run during an hw run: never on a core whose
// figures are measured (an RT or nRT node's core), so that the runner, its row writes and
// progress, the engine thread, the DDS participant's threads and the supervisors of external
// commands take nothing from the measured work (docs/design.md section 5, hw/README.md).
//
// Contract:
// - plan_housekeeping() is pure: it picks the CPUs from the usable ones and the run's cores.
// - HousekeepingPin pins the calling thread (the runner's main thread, before it starts any
//   other thread: every thread it creates later inherits the mask, Cyclone DDS's included) and
//   publishes the CPUs for the processes rosguard forks (housekeeping_cpus()); its destructor
//   restores the thread's previous mask and clears them. One at a time per process; construct
//   and destroy it on the same thread.
// - thread_placements() reads /proc/self/task and sched_getaffinity for every thread.
#pragma once

#include <sched.h>
#include <sys/types.h>

#include <set>
#include <string>
#include <vector>

namespace rosguard::hw {

struct HousekeepingPlan {
  enum class Kind {
    Spare,             // usable CPUs no node of the run uses
    Controller,        // no spare CPU: the controller's own core(s), which no RT / nRT node uses
    SharedController,  // neither: the controller's core(s), shared with a node (warned)
    None,              // no usable CPU at all (left unpinned)
  };
  Kind kind = Kind::None;
  std::vector<int> cpus;  // ascending
  std::string detail;     // one sentence: which CPUs and why
};

// `usable`: CPUs this process may use; `measured`: the RT and nRT nodes' cores of every point of
// the run; `controller`: the controller's cores.
HousekeepingPlan plan_housekeeping(const std::vector<int>& usable, const std::set<int>& measured,
                                   const std::set<int>& controller);

class HousekeepingPin {
 public:
  // Pins the calling thread to `cpus` (nothing when empty). `error` says why it failed, if so.
  explicit HousekeepingPin(const std::vector<int>& cpus);
  ~HousekeepingPin();
  HousekeepingPin(const HousekeepingPin&) = delete;
  HousekeepingPin& operator=(const HousekeepingPin&) = delete;
  const std::string& error() const { return error_; }

 private:
  bool pinned_ = false;
  cpu_set_t old_{};
  std::string error_;
};

// The CPUs a HousekeepingPin holds now; empty when none does. Read before a fork: the
// supervisor of an external command moves itself there once its command has started.
std::vector<int> housekeeping_cpus();

// One thread of this process and the CPUs it may run on.
struct ThreadPlacement {
  pid_t tid = 0;
  std::string name;
  std::vector<int> cpus;
};
std::vector<ThreadPlacement> thread_placements();

// "0-3, 6" for {0, 1, 2, 3, 6}; "none" for an empty list.
std::string cpu_ranges(const std::vector<int>& cpus);

}  // namespace rosguard::hw

// The processes `rosguard guard` regulates: every thread of another process whose CPU affinity is
// exactly one nRT core ("pinned" to it, e.g. `taskset -c 2 stress-ng ...`).
//
// Contract:
// - CoreTasks is owned by the guard's main thread: rescan() finds the pinned threads, applies the
//   throttle's needs to new ones (idle: SCHED_IDLE; freezer: their process moves into the core's
//   cgroup) and forgets those that ended; restore() (also run by the destructor) puts every thread
//   still alive back as it was (policy, nice value, cgroup). fifo needs nothing of them.
// - CpuTimeGroup is a CounterGroup read by the controller thread: the CPU time (ns) of the threads
//   pinned to its core, cumulative (threads that ended keep their last reading). It never blocks
//   on the main thread: it takes the latest list rescan() published with a try_lock. It reads
//   each thread's perf task clock (a software event, exact at every read: the kernel brings a
//   running thread's clock up to date) where the host opens one (task_clock_unavailable()), else
//   /proc/<tid>/schedstat, which a running thread's scheduler tick updates (4 ms at HZ=250).
// - Threads under a real-time policy are left alone (noted once): the guard regulates work that
//   the scheduler can preempt, not another real-time program.
// - Crash safety: with a record file (the guard's `state_dir`), every change CoreTasks makes to
//   another process (a thread moved to SCHED_IDLE, a process moved into a freezer cgroup, the
//   cgroups themselves) is written there before it takes effect, atomically (rename), and the
//   file goes when restore() has undone everything. repair() reads the file a killed guard left
//   and undoes what it says (cgroups thawed, processes back in their cgroups, threads back to
//   their policy; only threads with the recorded start time, so a reused pid is left alone).
#pragma once

#include <sched.h>
#include <sys/types.h>

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "hw/pmc_source/pmc_source.h"
#include "hw/throttle/throttle.h"

namespace rosguard::hw {

// Why this host opens no perf task clock on a thread (nullopt: it does).
std::optional<std::string> task_clock_unavailable();

class CpuTimeGroup : public CounterGroup {
 public:
  // task_clock: read perf task clocks (else schedstat).
  explicit CpuTimeGroup(bool task_clock) : task_clock_(task_clock) {}
  std::size_t size() const override { return 1; }
  void read(std::span<CounterValue> out) override;
  // Main thread: the threads pinned to the core now.
  void publish(std::vector<pid_t> tids);

 private:
  std::mutex mutex_;
  std::vector<pid_t> published_;  // guarded by mutex_
  // CPU time of a thread in ns, or -1 when it is gone (controller thread).
  long long thread_ns(pid_t tid);

  const bool task_clock_;
  // Controller thread only:
  std::vector<pid_t> tids_;
  std::map<pid_t, std::unique_ptr<CounterGroup>> clocks_;  // task_clock_: each thread's
  std::map<pid_t, std::uint64_t> last_;                    // CPU time since first seen pinned
  std::map<pid_t, std::uint64_t> base_;                    // its CPU time when first seen
  std::uint64_t ended_ns_ = 0;
  TimeNs first_ = -1;
};

class CoreTasks {
 public:
  struct Core {
    int core = 0;
    FreezerCgroup* cgroup = nullptr;  // freezer: where its processes go
    CpuTimeGroup* cputime = nullptr;  // cputime source: fed by rescan()
  };
  // record: the crash-safety file ("" for none). pin: process names (/proc/<pid>/comm) whose
  // threads not pinned to one CPU are pinned to one nRT core each (round robin over the nRT cores
  // their affinity allows) and so regulated; their affinity is given back by restore().
  CoreTasks(ThrottleKind kind, std::vector<Core> cores, std::string record = "",
            std::vector<std::string> pin = {});
  ~CoreTasks();
  CoreTasks(const CoreTasks&) = delete;
  CoreTasks& operator=(const CoreTasks&) = delete;

  struct Change {
    int core = 0;
    pid_t pid = 0, tid = 0;
    std::string comm;
    bool added = true;  // false: ended
    std::string note;   // what was applied, or why not
  };
  // Returns what changed since the last rescan. A Change with core -1 is a thread of a process in
  // `pin` that the guard left alone (note: why).
  std::vector<Change> rescan();
  // Processes ("comm pid") found by the rescans since the last call whose threads may run on an
  // nRT core but are not pinned to one (and not in `pin`): not regulated.
  std::vector<std::string> take_unregulated();
  void restore();
  std::size_t count(int core) const;

  // Undoes what the record at `path` says a guard that did not stop cleanly left behind; returns
  // one line per repair (nothing when there is no record). Throws RunError when the guard that
  // wrote it still runs.
  static std::vector<std::string> repair(const std::string& path);

 private:
  struct Task {
    int core = 0;
    pid_t pid = 0;
    int policy = 0;
    int priority = 0;
    int nice = 0;
    unsigned long long start_time = 0;  // /proc/<tid>/stat field 22: tells a reused tid apart
    bool idle_applied = false;
  };
  struct Pinned {
    unsigned long long start_time = 0;
    std::string cpus;  // its affinity before, as a CPU list ("0-3")
  };
  void save() const;
  // A thread of a process named in pin_ whose affinity is not one CPU: pinned to an nRT core it
  // allows (recorded first), returned; -1 when none (`why` says so where it is worth a line).
  int pin(pid_t pid, pid_t tid, const cpu_set_t& set, std::string& why);

  ThrottleKind kind_;
  std::vector<Core> cores_;
  std::string record_;
  std::vector<std::string> pin_;
  std::map<pid_t, Pinned> pinned_;          // by tid: threads the guard pinned
  std::map<pid_t, std::size_t> next_core_;  // by pid: round robin over its allowed nRT cores
  std::set<pid_t> not_pinned_;              // processes of pin_ already said to have no nRT core
  std::set<pid_t> unregulated_;  // processes that may run on an nRT core, unpinned, not in pin_
  std::vector<std::string> unregulated_new_;
  std::set<pid_t> glimpsed_;  // such processes the last rescan saw
  std::uint64_t scans_ = 0;
  std::map<pid_t, Task> tasks_;  // by tid
  struct Moved {
    std::string cgroup;  // the process's cgroup before it was moved
    unsigned long long start_time = 0;
  };
  std::map<pid_t, Moved> moved_;  // by pid (freezer)
  std::string cgroup_mount_;
};

}  // namespace rosguard::hw

// Workloads of the hw backend: built-in kernels run in the calling thread (the node's NCT or RT
// thread), external commands run as a child process pinned to the node's core.
//
// Contract:
// - make_workload() runs on the engine's thread before any node thread starts: it allocates and
//   pre-faults buffers and calibrates proxies, so a run does no allocation and no page faults.
// - BuiltinWorkload::run() is called from one thread at a time. It publishes its progress through
//   WorkCounters (see work_counters.h) every 64 lines and checks `stop` as often; it returns the
//   fraction of a run completed (1.0 unless stopped).
// - CommandProcess owns a command and everything it starts, through a supervisor process that is
//   their subreaper (hw/workload/supervisor.h): the destructor has it kill (SIGKILL) and reap
//   them all, and it does the same by itself if rosguard dies, so no external program outlives
//   its node, however the run ends. Construct, use and destroy it on one thread: the supervisor
//   takes that thread's exit for rosguard's death.
#pragma once

#include <sys/types.h>

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "hw/common/sys.h"
#include "hw/executor/executor.h"
#include "hw/workload/work_counters.h"
#include "scenario/scenario.h"

namespace rosguard::hw {

class BuiltinWorkload {
 public:
  virtual ~BuiltinWorkload() = default;
  virtual std::string_view kernel() const = 0;
  // Work units (cache lines touched) in one run.
  virtual std::uint64_t units_per_run() const = 0;
  virtual double run(const std::atomic<bool>& stop, WorkCounters& counters) = 0;
};

// Throws InputError naming the workload when its "hw" part cannot be run.
std::unique_ptr<BuiltinWorkload> make_builtin_workload(const WorkloadInfo& info);

// The latency kernel's chase order: next[i] is the line visited after line i. A random cyclic
// permutation (one cycle through all `lines`), the same for the same seed.
std::vector<std::uint32_t> chase_cycle(std::size_t lines, std::uint64_t seed);

// Proxy calibration on this host: ALU iterations per line so that the proxy reaches its target
// bandwidth (instrumented metric) on an idle core. Cached per process.
struct ProxyCalibration {
  double ns_per_line = 0.0;  // touching one line alone
  double ns_per_alu = 0.0;   // one compute iteration
  std::uint32_t alu_per_line = 0;
  double achievable_mbps = 0.0;  // with alu_per_line = 0
};
ProxyCalibration calibrate_proxy(double target_mbps, std::uint32_t working_set_kb);

class CommandProcess {
 public:
  // Forks the supervisor, which forks the command in its own process group, pinned to
  // spec.core, under SCHED_OTHER with the nice value of spec.priority when spec.sched is Fifo or
  // Other: below every SCHED_FIFO callback of the node, so THR preempts it, and nothing it forks
  // can spin under a real-time policy; under SCHED_IDLE when spec.sched is Idle (the idle
  // throttle). The command waits for start(). Throws RunError when the
  // supervisor cannot be set up (fork, prctl).
  // `cwd`: the directory it starts in (empty: rosguard's).
  CommandProcess(const std::vector<std::string>& argv, const ThreadSpec& spec,
                 std::string cwd = {});
  ~CommandProcess();
  CommandProcess(const CommandProcess&) = delete;
  CommandProcess& operator=(const CommandProcess&) = delete;

  // The command's pid (not the supervisor's): what to count, from exec on.
  pid_t pid() const { return pid_; }
  // Lets the command exec. Throws RunError when exec fails (command not found, ...).
  void start();
  // Blocks until the command exits (true; what it started is killed and reaped with it) or
  // `stop_fd` becomes readable (false).
  bool wait(int stop_fd);
  // The command's exit status as waitpid gives it (valid after wait() returned true).
  int status() const { return status_; }
  // Kills the command and everything it started, and reaps them; returns once all are gone.
  void kill();

 private:
  void reap();

  std::vector<std::string> argv_;
  std::string cwd_;
  pid_t pid_ = -1;         // the command
  pid_t supervisor_ = -1;  // our child; its wait status mirrors the command's
  Fd go_;                  // write end: one byte lets the command exec
  Fd report_;              // read end: SupervisorReport messages, EOF once the command exec'd
  Fd pidfd_;               // the supervisor's
  bool reaped_ = false;
  int status_ = 0;
};

// Describes an exit status: "exit 0", "signal 9 (Killed)".
std::string describe_status(int status);

}  // namespace rosguard::hw

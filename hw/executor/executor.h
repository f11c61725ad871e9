// Executors: one OS thread per callback group, pinned to a core, under SCHED_FIFO priorities.
//
// Contract:
// - RtThread starts a thread with SIGINT / SIGTERM blocked (the runner's main thread handles
//   them), applies its ThreadSpec inside the new thread, reports how that went (outcome()) before
//   the constructor returns, then runs the body. The destructor joins; an exception escaping the
//   body is kept (error()) and reported through the on_error callback.
// - ScopedSched applies a spec to the calling thread and restores the previous policy, priority
//   and affinity when destroyed (RAII: no thread is left under SCHED_FIFO by mistake).
// - Where SCHED_FIFO or the core is not available the thread falls back (SCHED_OTHER with a nice
//   value that keeps the order; or no pinning) and SchedOutcome says so: callers turn it into a
//   manifest fallback and a warning, never silently.
// - SchedOps wraps the system calls so tests can inject EPERM / EINVAL.
#pragma once

#include <pthread.h>
#include <sched.h>
#include <sys/types.h>

#include <atomic>
#include <exception>
#include <functional>
#include <string>
#include <thread>

namespace rosguard::hw {

// Idle: SCHED_IDLE (the work under the idle throttle, hw/throttle/throttle.h); never falls back.
enum class SchedClass { Fifo, Other, Idle };

// SCHED_FIFO priorities. On an nRT core: CFB > THR > PMC > NCT (the paper's order); the controller
// is above everything so it may share a core on small machines; an RT node sits between THR and
// PMC so the controller preempts it when they share a core.
namespace prio {
// The engine's own thread while a point runs: it mostly sleeps, but must not be starved when
// every core runs SCHED_FIFO node threads (it starts activations, sees stop requests).
inline constexpr int kEngine = 70;
inline constexpr int kController = 60;
inline constexpr int kCfb = 50;
inline constexpr int kThr = 40;
inline constexpr int kRt = 35;
inline constexpr int kPmc = 30;
inline constexpr int kNct = 20;
// The nice value used instead of a SCHED_FIFO priority when falling back to SCHED_OTHER: keeps
// the order (CFS weights differ by ~1.25x per step; -20 vs 19 is ~6000x).
int nice_for(int fifo_priority);
}  // namespace prio

// One step of a spin loop (THR, idle spinners): tells the core, and a hypervisor, that this
// thread only waits.
inline void cpu_relax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__)
  asm volatile("yield" ::: "memory");
#endif
}

struct ThreadSpec {
  std::string name;  // at most 15 characters are kept (pthread_setname_np); empty: unchanged
  int core = -1;     // -1: not pinned
  SchedClass sched = SchedClass::Fifo;
  int priority = prio::kNct;  // SCHED_FIFO priority (nice_for() under SCHED_OTHER; unused: Idle)
};

struct SchedOps {
  std::function<int(pthread_t, std::size_t, const cpu_set_t*)> set_affinity;
  std::function<int(pthread_t, int, const sched_param*)> set_scheduler;
  std::function<int(pid_t, int)> set_nice;  // setpriority(PRIO_PROCESS, tid, nice)
};
const SchedOps& system_sched_ops();

struct SchedOutcome {
  bool pinned = true;  // on the requested core (or none requested)
  bool fifo = true;    // under SCHED_FIFO (or not requested)
  bool idle = true;    // under SCHED_IDLE (or not requested)
  std::string detail;  // why a fallback was taken, naming the thread; empty when none
  std::string fifo_error, nice_error, pin_error, idle_error;  // errno texts of what was refused
};

// Applies `spec` to the calling thread. Never throws: failures become fallbacks.
SchedOutcome apply_to_current_thread(const ThreadSpec& spec, const SchedOps& ops);

class ScopedSched {
 public:
  ScopedSched(const ThreadSpec& spec, const SchedOps& ops = system_sched_ops());
  ~ScopedSched();
  ScopedSched(const ScopedSched&) = delete;
  ScopedSched& operator=(const ScopedSched&) = delete;
  const SchedOutcome& outcome() const { return outcome_; }

 private:
  int old_policy_ = SCHED_OTHER;
  sched_param old_param_{};
  cpu_set_t old_affinity_{};
  int old_nice_ = 0;
  SchedOutcome outcome_;
};

class RtThread {
 public:
  using ErrorHandler = std::function<void(const std::string& thread, std::exception_ptr)>;
  RtThread(ThreadSpec spec, std::function<void()> body, ErrorHandler on_error = {},
           const SchedOps& ops = system_sched_ops());
  ~RtThread();
  RtThread(const RtThread&) = delete;
  RtThread& operator=(const RtThread&) = delete;

  const ThreadSpec& spec() const { return spec_; }
  const SchedOutcome& outcome() const { return outcome_; }
  pid_t tid() const { return tid_; }
  void join();
  std::exception_ptr error() const { return error_; }

 private:
  ThreadSpec spec_;
  SchedOutcome outcome_;
  pid_t tid_ = 0;
  std::exception_ptr error_;
  std::thread thread_;
};

}  // namespace rosguard::hw

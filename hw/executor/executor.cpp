#include "hw/executor/executor.h"

#include <signal.h>
#include <sys/resource.h>

#include <cerrno>
#include <latch>

#include "hw/common/sys.h"

namespace rosguard::hw {

int prio::nice_for(int p) {
  if (p >= kCfb) return -20;
  if (p >= kThr) return -15;
  if (p >= kRt) return -10;
  if (p >= kPmc) return -5;
  return 0;
}

const SchedOps& system_sched_ops() {
  static const SchedOps ops{
      [](pthread_t t, std::size_t n, const cpu_set_t* s) {
        return ::pthread_setaffinity_np(t, n, s);
      },
      [](pthread_t t, int policy, const sched_param* p) {
        return ::pthread_setschedparam(t, policy, p);
      },
      [](pid_t tid, int nice) {
        return ::setpriority(PRIO_PROCESS, static_cast<id_t>(tid), nice) == 0 ? 0 : errno;
      }};
  return ops;
}

SchedOutcome apply_to_current_thread(const ThreadSpec& spec, const SchedOps& ops) {
  SchedOutcome out;
  const pthread_t self = ::pthread_self();
  if (!spec.name.empty()) ::pthread_setname_np(self, spec.name.substr(0, 15).c_str());
  if (spec.core >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(spec.core, &set);
    if (const int err = ops.set_affinity(self, sizeof set, &set); err != 0) {
      out.pinned = false;
      out.pin_error = errno_text(err);
      out.detail = "thread " + spec.name + ": cannot pin to core " + std::to_string(spec.core) +
                   " (" + errno_text(err) + "); it runs unpinned";
    }
  }
  const auto fall_back_to_nice = [&](const std::string& why) {
    out.fifo = false;
    const int nice = prio::nice_for(spec.priority);
    const int err = ops.set_nice(current_tid(), nice);
    std::string d = "thread " + spec.name + ": " + why + "; runs under SCHED_OTHER with nice " +
                    std::to_string(nice);
    if (err != 0) {
      out.nice_error = errno_text(err);
      d += " (setting the nice value failed too: " + out.nice_error + ")";
    }
    out.detail += (out.detail.empty() ? "" : "; ") + d;
  };
  if (spec.sched == SchedClass::Fifo) {
    sched_param p{};
    p.sched_priority = spec.priority;
    if (const int err = ops.set_scheduler(self, SCHED_FIFO, &p); err != 0) {
      out.fifo_error = errno_text(err);
      fall_back_to_nice("SCHED_FIFO priority " + std::to_string(spec.priority) + " refused (" +
                        errno_text(err) + ")");
    }
  } else if (spec.sched == SchedClass::Idle) {
    sched_param p{};
    if (const int err = ops.set_scheduler(self, SCHED_IDLE, &p); err != 0) {
      out.idle = false;
      out.idle_error = errno_text(err);
      out.detail += (out.detail.empty() ? "" : "; ") + std::string("thread ") + spec.name +
                    ": SCHED_IDLE refused (" + out.idle_error + "); it runs under SCHED_OTHER";
    }
  } else {
    out.fifo = true;  // not requested: nothing to report
    // Explicitly: a thread inherits its creator's policy, and a SCHED_FIFO creator (the engine
    // thread) would otherwise make it a FIFO thread at the creator's priority.
    sched_param p{};
    ops.set_scheduler(self, SCHED_OTHER, &p);
    ops.set_nice(current_tid(), prio::nice_for(spec.priority));
  }
  return out;
}

ScopedSched::ScopedSched(const ThreadSpec& spec, const SchedOps& ops) {
  const pthread_t self = ::pthread_self();
  ::pthread_getschedparam(self, &old_policy_, &old_param_);
  CPU_ZERO(&old_affinity_);
  ::pthread_getaffinity_np(self, sizeof old_affinity_, &old_affinity_);
  errno = 0;
  old_nice_ = ::getpriority(PRIO_PROCESS, static_cast<id_t>(current_tid()));
  outcome_ = apply_to_current_thread(spec, ops);
}

ScopedSched::~ScopedSched() {
  const pthread_t self = ::pthread_self();
  ::pthread_setschedparam(self, old_policy_, &old_param_);
  ::pthread_setaffinity_np(self, sizeof old_affinity_, &old_affinity_);
  ::setpriority(PRIO_PROCESS, static_cast<id_t>(current_tid()), old_nice_);
}

RtThread::RtThread(ThreadSpec spec, std::function<void()> body, ErrorHandler on_error,
                   const SchedOps& ops)
    : spec_(std::move(spec)) {
  std::latch ready(1);
  // The new thread inherits the signal mask: block the stop signals so they reach the main thread.
  sigset_t block, old;
  sigemptyset(&block);
  sigaddset(&block, SIGINT);
  sigaddset(&block, SIGTERM);
  ::pthread_sigmask(SIG_BLOCK, &block, &old);
  thread_ = std::thread(
      [this, &ready, &ops, body = std::move(body), on_error = std::move(on_error)]() mutable {
        std::exception_ptr err;
        try {
          ScopedSched sched(spec_, ops);
          outcome_ = sched.outcome();
          tid_ = current_tid();
          ready.count_down();
          try {
            body();
          } catch (...) {
            err = std::current_exception();
          }
        } catch (...) {
          err = std::current_exception();
          ready.count_down();
        }
        if (err) {
          error_ = err;
          if (on_error) on_error(spec_.name, err);
        }
      });
  ::pthread_sigmask(SIG_SETMASK, &old, nullptr);
  ready.wait();
}

void RtThread::join() {
  if (thread_.joinable()) thread_.join();
}

RtThread::~RtThread() {
  join();
}

}  // namespace rosguard::hw

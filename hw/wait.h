// The wait protocol of the hw engine's thread: futex waits on the engine's Waker with named
// timeouts, and the box that collects the first error of any node thread.
//
// Contract: wait_for() and ErrorBox::failed() / message() are called from the engine's thread;
// ErrorBox::handler() is given to node threads, which call it from their own thread on error.
#pragma once

#include <atomic>
#include <exception>
#include <mutex>
#include <string>

#include "core/error.h"
#include "hw/common/clock.h"
#include "hw/executor/executor.h"
#include "hw/topic/waker.h"

namespace rosguard::hw {

// A wait rechecks its stop condition at least this often, even without a wake-up.
inline constexpr TimeNs kWaitRecheckNs = 100 * kNsPerMs;
// After the last RT node finished, how long beyond the watchdog the controller may take to
// process every enable / disable signal (the last OFF, the last activation's accounting).
inline constexpr TimeNs kSignalsGraceNs = 500 * kNsPerMs;
// A silent controller (fault injection): how long beyond twice the watchdog the nodes may take to
// return to nominal on their own.
inline constexpr TimeNs kWatchdogGraceNs = 500 * kNsPerMs;

// Waits on `waker` until pred() holds. SIGINT / SIGTERM interrupt the futex wait (the runner's
// handlers do not restart system calls, and node threads block those signals, so they reach
// this thread); kWaitRecheckNs is only a safety net. Returns false when stopped or failed, or
// when `timeout_ns` (>= 0) passed first.
template <class Pred, class Stop>
bool wait_for(Waker& waker, Pred pred, Stop stop, TimeNs timeout_ns = -1) {
  const TimeNs give_up = timeout_ns < 0 ? -1 : now_ns() + timeout_ns;
  while (true) {
    const auto epoch = waker.epoch();
    if (pred()) return true;
    if (stop()) return false;
    const TimeNs now = now_ns();
    if (give_up >= 0 && now >= give_up) return false;
    TimeNs deadline = now + kWaitRecheckNs;
    if (give_up >= 0) deadline = std::min(deadline, give_up);
    waker.wait(epoch, deadline);
  }
}

// Collects errors from node threads; the first one fails the point.
class ErrorBox {
 public:
  explicit ErrorBox(Waker& waker) : waker_(waker) {}
  RtThread::ErrorHandler handler() {
    return [this](const std::string& thread, std::exception_ptr e) {
      const std::string what = exception_text(e);
      {
        std::lock_guard lock(mu_);
        if (message_.empty()) message_ = "thread " + thread + ": " + what;
      }
      failed_.store(true, std::memory_order_release);
      waker_.notify();
    };
  }
  bool failed() const { return failed_.load(std::memory_order_acquire); }
  std::string message() const {
    std::lock_guard lock(mu_);
    return message_;
  }

 private:
  Waker& waker_;
  mutable std::mutex mu_;
  std::string message_;
  std::atomic<bool> failed_{false};
};

}  // namespace rosguard::hw

// Waker: the futex a subscriber sleeps on. Publishers notify() it after delivering a message; the
// subscriber wait()s with an absolute CLOCK_MONOTONIC deadline. No sleep-polling anywhere.
//
// Contract: any number of notifiers, one waiting thread at a time (its owner). Usage:
//   const auto e = waker.epoch();   // before checking for work
//   ... take messages; if none: waker.wait(e, deadline);
// A notify() after epoch() makes wait() return at once, so no wake-up is lost.
#pragma once

#include <atomic>
#include <cstdint>

#include "core/types.h"

namespace rosguard::hw {

class Waker {
 public:
  std::uint32_t epoch() const { return seq_.load(std::memory_order_seq_cst); }
  void notify();
  // Returns false on timeout. deadline_ns < 0: no deadline. Returns early (true) on EINTR so the
  // caller can look at its stop flags.
  bool wait(std::uint32_t epoch, TimeNs deadline_ns);

 private:
  std::atomic<std::uint32_t> seq_{0};
  std::atomic<std::uint32_t> waiters_{0};
};

}  // namespace rosguard::hw

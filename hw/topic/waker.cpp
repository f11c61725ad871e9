#include "hw/topic/waker.h"

#include <linux/futex.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <climits>

#include "hw/common/clock.h"

namespace rosguard::hw {

void Waker::notify() {
  seq_.fetch_add(1, std::memory_order_seq_cst);
  // Skip the system call when nobody sleeps (a publish then costs a few ns).
  if (waiters_.load(std::memory_order_seq_cst) != 0)
    ::syscall(SYS_futex, reinterpret_cast<std::uint32_t*>(&seq_), FUTEX_WAKE_PRIVATE, INT_MAX,
              nullptr, nullptr, 0);
}

bool Waker::wait(std::uint32_t epoch, TimeNs deadline_ns) {
  waiters_.fetch_add(1, std::memory_order_seq_cst);
  bool woken = true;
  if (seq_.load(std::memory_order_seq_cst) == epoch) {
    timespec ts{};
    if (deadline_ns >= 0) ts = to_timespec(deadline_ns);
    // FUTEX_WAIT_BITSET takes an absolute CLOCK_MONOTONIC deadline.
    const long r =
        ::syscall(SYS_futex, reinterpret_cast<std::uint32_t*>(&seq_), FUTEX_WAIT_BITSET_PRIVATE,
                  epoch, deadline_ns >= 0 ? &ts : nullptr, nullptr, FUTEX_BITSET_MATCH_ANY);
    if (r != 0 && errno == ETIMEDOUT) woken = false;
  }
  waiters_.fetch_sub(1, std::memory_order_seq_cst);
  return woken;
}

}  // namespace rosguard::hw

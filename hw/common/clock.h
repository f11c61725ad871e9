// Monotonic time for the hw backend: integer nanoseconds of CLOCK_MONOTONIC, the clock every
// stamp carried through topics uses (so stamps from different threads and cores compare).
#pragma once

#include <time.h>

#include <cerrno>

#include "core/types.h"

namespace rosguard::hw {

inline TimeNs now_ns() {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<TimeNs>(ts.tv_sec) * kNsPerS + ts.tv_nsec;
}

// CPU time of the calling thread (a system call, not vDSO: about 1 us on a VM).
inline TimeNs thread_cpu_ns() {
  timespec ts{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<TimeNs>(ts.tv_sec) * kNsPerS + ts.tv_nsec;
}

inline timespec to_timespec(TimeNs t) {
  return {static_cast<time_t>(t / kNsPerS), static_cast<long>(t % kNsPerS)};
}

// Sleeps until absolute monotonic time `t` (EINTR retried).
inline void sleep_until(TimeNs t) {
  const timespec ts = to_timespec(t);
  while (::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

inline double ns_to_us(TimeNs t) {
  return static_cast<double>(t) / 1e3;
}

}  // namespace rosguard::hw

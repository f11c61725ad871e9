// Monotonic time for the hw backend: integer nanoseconds of CLOCK_MONOTONIC, the clock every
// stamp carried through topics uses (so stamps from different threads and cores compare).
#pragma once

#include <time.h>

#include <cerrno>
#include <cstdio>
#include <string>

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

// A timed measurement counts only if its thread was on its core at least this share of the wall
// time (its CPU time over the elapsed time); else it is taken again, at most kOnCoreAttempts times
// in all. SCHED_FIFO threads still lose the CPU to RT throttling (sched_rt_runtime_us: 50 ms of
// every second once a core's real-time tasks used the rest, which a run of back-to-back
// SCHED_FIFO measurements reaches) and to higher priorities; under SCHED_OTHER to anything.
inline constexpr double kMinOnCore = 0.95;
inline constexpr int kOnCoreAttempts = 3;

inline timespec to_timespec(TimeNs t) {
  return {static_cast<time_t>(t / kNsPerS), static_cast<long>(t % kNsPerS)};
}

// Sleeps until absolute monotonic time `t` (EINTR retried).
inline void sleep_until(TimeNs t) {
  const timespec ts = to_timespec(t);
  while (::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

// Now, CLOCK_REALTIME in UTC, as logs write it: "2026-11-27T15:54:39.898Z".
inline std::string wall_clock_iso() {
  timespec ts{};
  ::clock_gettime(CLOCK_REALTIME, &ts);
  tm utc{};
  ::gmtime_r(&ts.tv_sec, &utc);
  char buf[96];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02d.%03ldZ", utc.tm_year + 1900,
                utc.tm_mon + 1, utc.tm_mday, utc.tm_hour, utc.tm_min, utc.tm_sec,
                ts.tv_nsec / 1000000);
  return buf;
}

inline double ns_to_us(TimeNs t) {
  return static_cast<double>(t) / 1e3;
}

}  // namespace rosguard::hw

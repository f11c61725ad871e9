// SIGINT / SIGTERM during `rosguard run`: the handler only records the signal; the run stops
// dispatching tasks, lets the running ones return their nodes to nominal, keeps complete rows,
// and exits 130 / 143. Forked workers restore the default handlers (see task_pool.cpp).
#pragma once

#include <signal.h>

namespace rosguard {

// The stop signal received since the current StopSignalGuard was installed; 0 when none.
int stop_signal();

// Installs the recording handler for SIGINT and SIGTERM (without SA_RESTART, so that blocking
// calls return EINTR and see the flag); restores the previous handlers on destruction.
class StopSignalGuard {
 public:
  StopSignalGuard();
  ~StopSignalGuard();
  StopSignalGuard(const StopSignalGuard&) = delete;
  StopSignalGuard& operator=(const StopSignalGuard&) = delete;

 private:
  struct sigaction old_int_ {};
  struct sigaction old_term_ {};
};

}  // namespace rosguard

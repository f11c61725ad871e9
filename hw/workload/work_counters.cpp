#include "hw/workload/work_counters.h"

#include <signal.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>

namespace rosguard::hw {
namespace {

// Fires watch w if its count reached `at`: queues its signal and moves `at` on.
void check(OverflowWatch& w, std::uint64_t count) noexcept {
  std::uint64_t at = w.at.load(std::memory_order_acquire);
  if (at == OverflowWatch::kNever || count < at) return;
  // The next overflow one period after this one, as a perf sampling event goes on; a chunk that
  // crossed several periods raises one signal.
  const std::uint64_t period = std::max<std::uint64_t>(w.period.load(std::memory_order_relaxed), 1);
  const std::uint64_t next = std::max(at + period, count + 1);
  if (!w.at.compare_exchange_strong(at, next, std::memory_order_acq_rel)) return;  // re-armed
  siginfo_t info{};
  info.si_signo = w.sig.load(std::memory_order_relaxed);
  info.si_code = SI_QUEUE;
  info.si_pid = ::getpid();
  info.si_uid = ::getuid();
  info.si_value.sival_int = w.slot.load(std::memory_order_relaxed);
  // A thread that is gone (ESRCH) has no counter left to mark: nothing to do.
  ::syscall(SYS_rt_tgsigqueueinfo, info.si_pid, w.tid.load(std::memory_order_relaxed),
            info.si_signo, &info);
}

}  // namespace

void WorkCounters::check_watches() noexcept {
  for (std::size_t i = 0; i < watches.size(); ++i)
    check(watches[i], watched(i));
}

}  // namespace rosguard::hw

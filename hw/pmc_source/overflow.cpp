#include "hw/pmc_source/overflow.h"

#include <fcntl.h>
#include <linux/perf_event.h>
#include <signal.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <mutex>

#include "core/error.h"
#include "hw/common/clock.h"

namespace rosguard::hw {
namespace {

// The handler's table: which sink and entity an fd's signal marks. A slot is claimed (state 1)
// before it is written and published (state 2) after; the handler reads published slots only.
struct Slot {
  std::atomic<int> state{0};
  std::atomic<int> fd{-1};
  std::atomic<OverflowSink*> sink{nullptr};
  std::atomic<std::size_t> entity{0};
  std::atomic<std::size_t> event{0};
};
constexpr std::size_t kSlots = 256;
std::array<Slot, kSlots> g_slots;
constexpr int kQueued = -2;  // the fd of a slot whose signal is queued with its index

void mark(Slot& s, TimeNs t) noexcept {
  if (OverflowSink* sink = s.sink.load(std::memory_order_relaxed))
    sink->hit(s.entity.load(std::memory_order_relaxed), s.event.load(std::memory_order_relaxed), t);
}

void on_overflow(int, siginfo_t* info, void*) {
  const int saved = errno;
  const TimeNs t = now_ns();
  if (info->si_code == SI_QUEUE) {
    // Queued by a workload of this process (anyone else's is ignored): the slot is its value.
    const int i = info->si_value.sival_int;
    if (info->si_pid == ::getpid() && i >= 0 && static_cast<std::size_t>(i) < kSlots) {
      Slot& s = g_slots[static_cast<std::size_t>(i)];
      if (s.state.load(std::memory_order_acquire) == 2 &&
          s.fd.load(std::memory_order_relaxed) == kQueued)
        mark(s, t);
    }
  } else {
    for (Slot& s : g_slots)
      if (s.state.load(std::memory_order_acquire) == 2 &&
          s.fd.load(std::memory_order_relaxed) == info->si_fd)
        mark(s, t);
  }
  errno = saved;
}

void install_handler() {
  static std::once_flag once;
  std::call_once(once, [] {
    struct sigaction sa {};
    sa.sa_sigaction = on_overflow;
    sa.sa_flags = SA_SIGINFO | SA_RESTART;
    sigemptyset(&sa.sa_mask);
    if (::sigaction(overflow_signal(), &sa, nullptr) != 0)
      throw RunError("sigaction for the overflow signal: " + errno_text(errno));
  });
}

int take_slot(int fd, OverflowSink& sink, std::size_t entity, std::size_t event) {
  for (std::size_t i = 0; i < kSlots; ++i) {
    int free = 0;
    if (!g_slots[i].state.compare_exchange_strong(free, 1, std::memory_order_acq_rel)) continue;
    g_slots[i].fd.store(fd, std::memory_order_relaxed);
    g_slots[i].sink.store(&sink, std::memory_order_relaxed);
    g_slots[i].entity.store(entity, std::memory_order_relaxed);
    g_slots[i].event.store(event, std::memory_order_relaxed);
    g_slots[i].state.store(2, std::memory_order_release);
    return static_cast<int>(i);
  }
  throw RunError("more than 256 overflow counters at once");
}

void free_slot(int i) {
  Slot& s = g_slots[static_cast<std::size_t>(i)];
  s.state.store(1, std::memory_order_release);
  s.fd.store(-1, std::memory_order_relaxed);
  s.sink.store(nullptr, std::memory_order_relaxed);
  s.state.store(0, std::memory_order_release);
}

}  // namespace

int overflow_signal() {
  return SIGRTMIN + 2;
}

OverflowSink::OverflowSink(std::size_t entities, Waker& waker)
    : n_(entities),
      t_(std::make_unique<std::atomic<TimeNs>[]>(entities)),
      events_(std::make_unique<std::atomic<std::uint32_t>[]>(entities)),
      waker_(waker) {}

OverflowSink::Hit OverflowSink::take(std::size_t entity) {
  if (entity >= n_) return {};
  Hit h;
  h.events = events_[entity].exchange(0, std::memory_order_acq_rel);
  h.t = t_[entity].exchange(0, std::memory_order_acq_rel);
  return h;
}

void OverflowSink::hit(std::size_t entity, std::size_t event, TimeNs t) noexcept {
  if (entity >= n_) return;
  events_[entity].fetch_or(std::uint32_t{1} << (event % 32), std::memory_order_acq_rel);
  TimeNs none = 0;
  t_[entity].compare_exchange_strong(none, t, std::memory_order_acq_rel);
  waker_.notify();
}

int take_queued_slot(OverflowSink& sink, std::size_t entity, std::size_t event) {
  install_handler();
  return take_slot(kQueued, sink, entity, event);
}

void release_queued_slot(int slot) {
  if (slot >= 0 && static_cast<std::size_t>(slot) < kSlots) free_slot(slot);
}

PerfOverflowCounters::PerfOverflowCounters(std::vector<Fd> fds, std::vector<std::string> names,
                                           std::vector<std::uint64_t> min_periods)
    : OverflowCounters(std::move(names)),
      fds_(std::move(fds)),
      min_periods_(std::move(min_periods)),
      slots_(fds_.size(), -1) {
  min_periods_.resize(fds_.size(), 1);
}

PerfOverflowCounters::~PerfOverflowCounters() {
  for (std::size_t i = 0; i < fds_.size(); ++i) {
    if (periods_[i]) ::ioctl(fds_[i].get(), PERF_EVENT_IOC_DISABLE, 0);
    if (slots_[i] >= 0) free_slot(slots_[i]);
  }
}

void PerfOverflowCounters::claim(OverflowSink& sink, std::size_t entity) {
  install_handler();
  const f_owner_ex owner{F_OWNER_TID, current_tid()};
  for (std::size_t i = 0; i < fds_.size(); ++i) {
    const int fd = fds_[i].get();
    if (slots_[i] < 0) slots_[i] = take_slot(fd, sink, entity, i);
    const int flags = ::fcntl(fd, F_GETFL);
    if (::fcntl(fd, F_SETOWN_EX, &owner) != 0 || ::fcntl(fd, F_SETSIG, overflow_signal()) != 0 ||
        flags < 0 || ::fcntl(fd, F_SETFL, flags | O_ASYNC) != 0)
      throw RunError("cannot route the overflow signal of perf event '" + names_[i] +
                     "' to the controller thread (fcntl F_SETOWN_EX / F_SETSIG / O_ASYNC): " +
                     errno_text(errno));
  }
}

void PerfOverflowCounters::arm(std::span<const std::uint64_t> periods) {
  for (std::size_t i = 0; i < fds_.size(); ++i) {
    const std::uint64_t p = i < periods.size() ? periods[i] : 0;
    const int fd = fds_[i].get();
    if (p == 0) {
      if (periods_[i] && ::ioctl(fd, PERF_EVENT_IOC_DISABLE, 0) != 0)
        throw RunError("disarming the overflow counter of '" + names_[i] +
                       "': " + errno_text(errno));
      periods_[i] = 0;
      continue;
    }
    // A new period restarts the count towards the overflow from now, enabled or not.
    std::uint64_t period = std::max(p, min_periods_[i]);
    if (::ioctl(fd, PERF_EVENT_IOC_PERIOD, &period) != 0 ||
        (!periods_[i] && ::ioctl(fd, PERF_EVENT_IOC_ENABLE, 0) != 0))
      throw RunError("arming the overflow counter of '" + names_[i] + "' with a period of " +
                     std::to_string(period) + ": " + errno_text(errno));
    periods_[i] = period;
  }
}

}  // namespace rosguard::hw

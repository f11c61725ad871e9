// Overflow counters: MemGuard's PMU overflow interrupt through perf_event_open. One sampling perf
// event per metric event on an nRT node's thread; arming one with a period (in counts,
// PERF_EVENT_IOC_PERIOD) makes the kernel send the owner thread overflow_signal() once the thread
// has counted that many events (F_SETOWN_EX to the owner's tid, F_SETSIG, O_ASYNC). The signal's
// handler marks the counter's entity in the owner's OverflowSink and notifies the sink's Waker,
// the futex the owner (the controller thread) sleeps on anyway. Software events (task_clock,
// cpu_clock) overflow the same way as hardware ones, through the kernel's hrtimer.
//
// The instrumented source's counters are the built-in workloads' overflow watches
// (hw/workload/work_counters.h): the workload thread queues the same signal itself, with the
// handler's slot as its value, once its line count reaches the armed limit.
//
// Contract:
// - Opened by a PmcSource (open_overflow) on a thread target, disarmed. claim() runs on the
//   owner thread: from then on only that thread gets their signals, and the sink must outlive
//   the counters. arm() / disarm() run on the owner thread.
// - A counter armed with period p signals after p more counts, then again every p counts until
//   it is armed again or disarmed (no event limit: re-arming never races an overflow the kernel
//   has taken but not yet signalled). The owner re-arms after every overflow it takes.
// - The handler only touches atomics and the futex (async-signal-safe); a signal for a counter
//   that is gone is ignored. Counters are destroyed by their owner or after it exited.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/types.h"
#include "hw/common/sys.h"
#include "hw/topic/waker.h"

namespace rosguard::hw {

// The real-time signal the overflow counters raise (SIGRTMIN + 2).
int overflow_signal();

// Where the overflow signals of one owner thread land, per entity.
class OverflowSink {
 public:
  OverflowSink(std::size_t entities, Waker& waker);

  struct Hit {
    TimeNs t = 0;              // CLOCK_MONOTONIC of the first signal not taken yet; 0: none
    std::uint32_t events = 0;  // bit i: the counter of event i signalled
  };
  // Owner thread: the entity's overflows since the last take().
  Hit take(std::size_t entity);
  // The signal handler's side.
  void hit(std::size_t entity, std::size_t event, TimeNs t) noexcept;

 private:
  std::size_t n_;
  std::unique_ptr<std::atomic<TimeNs>[]> t_;
  std::unique_ptr<std::atomic<std::uint32_t>[]> events_;
  Waker& waker_;
};

// One nRT node's overflow counters, one per metric event. Two kinds: perf sampling events (the
// perf and software sources) and the built-in workloads' own overflow watches (the instrumented
// source, hw/workload/work_counters.h), which queue the same signal themselves.
class OverflowCounters {
 public:
  virtual ~OverflowCounters() = default;
  OverflowCounters(const OverflowCounters&) = delete;
  OverflowCounters& operator=(const OverflowCounters&) = delete;

  std::size_t size() const { return names_.size(); }
  const std::string& name(std::size_t i) const { return names_.at(i); }
  // On the owner thread: their signals go to it and mark `entity` in `sink`. Throws RunError
  // when the kernel refuses.
  virtual void claim(OverflowSink& sink, std::size_t entity) = 0;
  // periods[i] > 0: counter i signals after that many more counts (at least its min period);
  // 0: counter i disarmed.
  virtual void arm(std::span<const std::uint64_t> periods) = 0;
  void disarm() { arm({}); }
  // The periods armed last, as the counters run them (0: disarmed).
  const std::vector<std::uint64_t>& periods() const { return periods_; }

 protected:
  explicit OverflowCounters(std::vector<std::string> names)
      : names_(std::move(names)), periods_(names_.size(), 0) {}

  std::vector<std::string> names_;
  std::vector<std::uint64_t> periods_;
};

// Perf sampling events: PERF_EVENT_IOC_PERIOD arms, F_SETOWN_EX / F_SETSIG route the signal.
class PerfOverflowCounters final : public OverflowCounters {
 public:
  // min_periods[i]: the shortest period counter i overflows after (the kernel runs its clock
  // events, task_clock and cpu_clock, on an hrtimer of at least 10 us); a shorter one is raised.
  PerfOverflowCounters(std::vector<Fd> fds, std::vector<std::string> names,
                       std::vector<std::uint64_t> min_periods);
  ~PerfOverflowCounters() override;
  // Throws RunError (fcntl's errno) when the kernel refuses.
  void claim(OverflowSink& sink, std::size_t entity) override;
  void arm(std::span<const std::uint64_t> periods) override;

 private:
  std::vector<Fd> fds_;
  std::vector<std::uint64_t> min_periods_;
  std::vector<int> slots_;  // in the handler's table; -1 none
};

// For counters that raise the overflow signal themselves (the instrumented source): a slot of
// the handler's table that marks `event` of `entity` in `sink` when this process queues the
// signal (rt_tgsigqueueinfo, si_code SI_QUEUE) with the slot as its value. Installs the handler.
int take_queued_slot(OverflowSink& sink, std::size_t entity, std::size_t event);
void release_queued_slot(int slot);

}  // namespace rosguard::hw

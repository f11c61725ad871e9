#include "platform/core.h"

#include <cmath>
#include <limits>

namespace rosguard::sim {
namespace {

constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
// A segment with fewer instructions left than this is finished (rounding of rate x time).
constexpr double kInstEpsilon = 1e-3;
// Wake-ups are armed at most this far ahead. SystemC keeps a cancelled timed notification in its
// event queue until its time comes, so re-arming a far-future wake-up at every preemption would
// grow the queue for the whole segment (and every queue operation with it). Armed lazily (a
// later wake-up never replaces a pending earlier one; an early wake-up just re-arms) and within
// this horizon, the queue holds a handful of entries per core.
constexpr TimeNs kWakeHorizonNs = 5 * kNsPerMs;

bool same_demand(const CoreDemand& a, const CoreDemand& b) {
  return a.cluster == b.cluster && a.phase == b.phase && a.resident_phase == b.resident_phase &&
         a.workload == b.workload && a.resident == b.resident;
}

}  // namespace

Core::Core(const sc_core::sc_module_name& name, int id, const SimPlatform& platform,
           MemorySystem& memory, Runtime& rt, TraceSink* trace, std::uint64_t seed)
    : sc_core::sc_module(name),
      id_(id),
      cluster_(platform.cluster_of(id)),
      f_ghz_(platform.freq_ghz()),
      callback_ipc_(platform.core.callback_ipc),
      idle_ipc_(platform.core.idle_loop_ipc),
      memory_(memory),
      rt_(rt),
      trace_(trace),
      overflow_timer_("overflow", rt, [this](TimeNs t) { overflow_timer(t); }) {
  if (platform.costs.preemption)
    preemption_cost_.emplace(*platform.costs.preemption,
                             stream_seed(seed, "core" + std::to_string(id) + "/preemption"));
  SC_METHOD(wake);
  sensitive << wake_ev_;
  dont_initialize();
  mem_index_ = memory_.attach(this);
}

void Core::start_work(WorkloadRun* run, Done on_end) {
  const TimeNs now = now_ns();
  sync(now);
  run_ = run;
  on_end_ = std::move(on_end);
  if (run_) held_workload_ = &run_->profile();
  dispatch(now);
}

void Core::stop_work() {
  const TimeNs now = now_ns();
  sync(now);
  run_ = nullptr;
  on_end_ = nullptr;
  dispatch(now);
}

void Core::post(Prio prio, TimeNs cost_ns, std::string label, Done done) {
  const TimeNs now = now_ns();
  sync(now);
  // The running workload is preempted: it pays its restart once the callbacks ahead of it are done.
  const bool preempts = running_ == Running::Work && preemption_cost_;
  callbacks_.push_back({prio, seq_++, cost_ns, std::move(label), std::move(done)});
  if (preempts)
    callbacks_.push_back({Prio::Resume, seq_++, preemption_cost_->draw_ns(), "resume", {}});
  dispatch(now);
}

void Core::set_throttle(bool on) {
  const TimeNs now = now_ns();
  sync(now);
  thr_ = on;
  dispatch(now);
}

const Pmu& Core::pmu() {
  sync(now_ns());
  return pmu_;
}

double Core::work_retired() {
  sync(now_ns());
  return run_ ? run_->retired_total() : 0.0;
}

CoreDemand Core::demand() const {
  CoreDemand d;
  d.cluster = cluster_;
  if (run_ && !run_->finished()) {
    d.workload = &run_->profile();
    d.resident = !thr_;
    d.resident_phase = &run_->phase();
    if (running_ == Running::Work) d.phase = &run_->phase();
  } else {  // idle or finished: its lines (if any) age out
    d.workload = held_workload_;
  }
  return d;
}

void Core::memory_changed() {
  const TimeNs now = now_ns();
  sync(now);
  dispatch(now);
}

std::size_t Core::top_callback() const {
  std::size_t best = kNone;
  for (std::size_t i = 0; i < callbacks_.size(); ++i) {
    const Pending& p = callbacks_[i];
    if (best == kNone || p.prio < callbacks_[best].prio ||
        (p.prio == callbacks_[best].prio && p.seq < callbacks_[best].seq))
      best = i;
  }
  return best;
}

void Core::sync(TimeNs now) {
  const TimeNs dt = now - last_;
  last_ = now;
  if (dt <= 0) return;
  const double ns = static_cast<double>(dt);
  const double cycles = f_ghz_ * ns;
  switch (running_) {
    case Running::Idle:
      break;
    case Running::Callback:
      pmu_[PmuEvent::CpuCycles] += cycles;
      pmu_[PmuEvent::InstRetired] += callback_ipc_ * cycles;
      callbacks_[running_cb_].remaining -= dt;
      break;
    case Running::Thr:
      pmu_[PmuEvent::CpuCycles] += cycles;
      pmu_[PmuEvent::InstRetired] += idle_ipc_ * cycles;
      break;
    case Running::Work: {
      const double n = rates_.inst_per_ns * ns;
      const double left = run_->remaining_in_segment();
      // The segment may end a fraction of a ns before `now` (wake-ups are whole ns).
      const double busy = n > left ? ns * left / n : ns;
      const double refill = rates_.refill_per_ns * busy;
      const double wb = rates_.wb_per_ns * busy;
      pmu_[PmuEvent::CpuCycles] += cycles;
      pmu_[PmuEvent::InstRetired] += rates_.inst_per_ns * busy;
      pmu_[PmuEvent::L2Refill] += refill;
      pmu_[PmuEvent::L2Wb] += wb;
      pmu_[PmuEvent::L3Access] += refill + wb;
      pmu_[PmuEvent::L3Refill] += rates_.l3_refill_per_ns * busy;
      run_->retire(rates_.inst_per_ns * busy);
      break;
    }
  }
}

void Core::dispatch(TimeNs now) {
  const std::size_t cb = top_callback();
  Running next = Running::Idle;
  if (cb != kNone && callbacks_[cb].prio <= Prio::Cfb)  // controller and CFB preempt THR
    next = Running::Callback;
  else if (thr_)
    next = Running::Thr;
  else if (cb != kNone)
    next = Running::Callback;
  else if (run_ && !run_->finished())
    next = Running::Work;
  running_ = next;
  running_cb_ = cb;

  TimeNs at = -1;
  if (next == Running::Callback) {
    Pending& p = callbacks_[cb];
    if (p.started < 0) p.started = now;
    at = now + std::max<TimeNs>(0, p.remaining);
  } else if (next == Running::Work) {
    rates_ = memory_.rates(mem_index_, run_->phase(), cluster_);
    const double left = run_->remaining_in_segment();
    const double ns = std::ceil(left / rates_.inst_per_ns);
    at = now + std::max<TimeNs>(1, static_cast<TimeNs>(ns));
  }

  const CoreDemand d = demand();
  if (!reported_valid_ || !same_demand(d, reported_)) {
    reported_ = d;
    reported_valid_ = true;
    memory_.mark_dirty();
  }

  wake_at_ = at;
  arm(now);
  if (overflow_fire_) overflow_rearm(now);
}

void Core::arm_overflow(std::vector<OverflowLimit> limits, Done fire) {
  const TimeNs now = now_ns();
  sync(now);
  overflow_ = std::move(limits);
  for (OverflowLimit& l : overflow_) {
    double slack = 1.0;  // bytes: strictly past the limit
    for (double b : l.bytes_per_count)
      slack += b;
    l.at_bytes += slack;
  }
  overflow_fire_ = overflow_.empty() ? Done{} : std::move(fire);
  if (overflow_fire_)
    overflow_rearm(now);
  else
    overflow_timer_.cancel();
}

void Core::disarm_overflow() {
  overflow_.clear();
  overflow_fire_ = nullptr;
  overflow_timer_.cancel();
}

std::optional<TimeNs> Core::overflow_crossing(TimeNs now) const {
  std::optional<TimeNs> best;
  for (const OverflowLimit& l : overflow_) {
    double value = 0.0;
    for (std::size_t e = 0; e < kPmuEvents; ++e)
      value += l.bytes_per_count[e] * pmu_.count[e];
    if (value >= l.at_bytes) return now;
    if (running_ != Running::Work) continue;  // callbacks and the THR loop move no data
    const auto per = [&](PmuEvent e) { return l.bytes_per_count[static_cast<std::size_t>(e)]; };
    const double rate = per(PmuEvent::L2Refill) * rates_.refill_per_ns +
                        per(PmuEvent::L2Wb) * rates_.wb_per_ns +
                        per(PmuEvent::L3Access) * (rates_.refill_per_ns + rates_.wb_per_ns) +
                        per(PmuEvent::L3Refill) * rates_.l3_refill_per_ns;
    if (rate <= 0.0) continue;
    const TimeNs at =
        now + std::max<TimeNs>(1, static_cast<TimeNs>(std::ceil((l.at_bytes - value) / rate)));
    if (!best || at < *best) best = at;
  }
  return best;
}

// Lazy, as arm() is: an earlier crossing replaces a pending later one; a later one leaves the
// pending timer, which re-checks when it fires.
void Core::overflow_rearm(TimeNs now) {
  const auto at = overflow_crossing(now);
  if (!at) return;
  if (!overflow_timer_.pending() || *at < overflow_timer_.when()) overflow_timer_.set(*at);
}

void Core::overflow_timer(TimeNs now) {  // a Timer's callback: already guarded
  if (!overflow_fire_) return;
  sync(now);
  const auto at = overflow_crossing(now);
  if (at && *at <= now) {
    Done fire = std::move(overflow_fire_);
    disarm_overflow();
    fire(now);
    return;
  }
  if (at) overflow_timer_.set(*at);
}

void Core::arm(TimeNs now) {
  if (wake_at_ < 0) return;  // a pending wake-up, if any, will find nothing to do
  const TimeNs target = std::min(wake_at_, now + kWakeHorizonNs);
  if (armed_at_ >= 0 && armed_at_ <= target) return;
  armed_at_ = target;
  if (target <= now)
    wake_ev_.notify(sc_core::SC_ZERO_TIME);
  else
    wake_ev_.notify(to_sc(target - now));
}

void Core::wake() {
  rt_.guarded([&] {
    const TimeNs now = now_ns();
    armed_at_ = -1;
    if (wake_at_ < 0 || now < wake_at_) {  // early (the horizon, or the end moved later)
      arm(now);
      return;
    }
    wake_at_ = -1;
    sync(now);
    if (running_ == Running::Callback && callbacks_[running_cb_].remaining <= 0) {
      Pending p = std::move(callbacks_[running_cb_]);
      callbacks_.erase(callbacks_.begin() + static_cast<std::ptrdiff_t>(running_cb_));
      running_ = Running::Idle;
      if (trace_) trace_->span(p.started, now, id_, "callbacks", p.label);
      if (p.done) p.done(now);
    } else if (running_ == Running::Work && run_->remaining_in_segment() <= kInstEpsilon) {
      if (!run_->next_segment()) {
        running_ = Running::Idle;
        Done on_end = on_end_;  // may restart the run or start another
        if (on_end) on_end(now);
      }
    }
    dispatch(now);
  });
}

}  // namespace rosguard::sim

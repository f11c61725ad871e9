#include "hw/nodes/nrt_node.h"

#include <sys/eventfd.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>

#include "core/error.h"
#include "hw/common/clock.h"

namespace rosguard::hw {
namespace {

const char* state_name(NodeState s) {
  return to_string(s).data();  // literals: null-terminated
}

}  // namespace

void ProcessCounters::read(std::span<CounterValue> out) {
  Generation* g = current_.load(std::memory_order_acquire);
  const std::size_t k = std::min(out.size(), n_);
  if (!g) {
    for (std::size_t i = 0; i < k; ++i)
      out[i] = {};
    return;
  }
  std::array<CounterValue, kMaxGroupEvents> cur{};
  g->group->read(std::span(cur.data(), n_));
  for (std::size_t i = 0; i < k; ++i)
    out[i] = {g->base[i].value + cur[i].value, g->base[i].time_enabled_ns + cur[i].time_enabled_ns,
              g->base[i].time_running_ns + cur[i].time_running_ns};
}

void ProcessCounters::next(std::unique_ptr<CounterGroup> group) {
  auto g = std::make_unique<Generation>();
  g->base.resize(n_);
  read(g->base);  // the finished processes' totals
  g->group = std::move(group);
  current_.store(g.get(), std::memory_order_release);
  generations_.push_back(std::move(g));
}

NrtRunner::NrtRunner(NrtConfig config, const WorkloadInfo& workload, const PmcSource& source,
                     Topic<ControlMsg>& control, Topic<SampleMsg>& samples, Waker& engine_waker,
                     RtThread::ErrorHandler on_error, TimeNs origin)
    : cfg_(std::move(config)),
      workload_(workload),
      source_(source),
      control_(control),
      samples_(samples),
      engine_waker_(engine_waker),
      on_error_(std::move(on_error)),
      origin_(origin),
      track_state_(cfg_.name + " state"),
      track_thr_(cfg_.name + " THR"),
      driver_(cfg_.sampling, cfg_.watchdog_ns),
      cfb_trace_(cfg_.trace),
      thr_trace_(cfg_.trace),
      pmc_trace_(cfg_.trace) {
  if (cfg_.group_events.size() > kMaxGroupEvents)
    throw RunError("nRT node " + cfg_.name + ": more than 8 events in one group");
  if (cfg_.foreign && cfg_.sampling != Sampling::External)
    throw ContractError("nRT node " + cfg_.name + ": a foreign node is sampled externally");
  if (!cfg_.foreign && !workload_.is_command()) builtin_ = make_builtin_workload(workload_);
  sched_ = throttle_sched(cfg_.throttle, cfg_.sched);
  if (cfg_.throttle == ThrottleKind::Freezer) {
    if (builtin_)
      throw RunError("nRT node " + cfg_.name +
                     ": the freezer throttle needs an external command (a built-in workload is a "
                     "thread of rosguard)");
    cgroup_ = std::make_unique<FreezerCgroup>(
        cfg_.freezer_root, "rosguard-" + std::to_string(::getpid()) + "-" + cfg_.name);
  }
  throttler_ = make_throttler(cfg_.throttle, cgroup_.get());
  stop_fd_ = Fd(::eventfd(0, EFD_CLOEXEC));
  if (!stop_fd_.valid()) throw RunError("eventfd: " + errno_text(errno));
  control_sub_ = control_.subscribe(cfb_waker_);
  sample_pub_ = samples_.add_publisher();
  activation_us_.reserve(1 << 14);
  pmc_us_.reserve(1 << 16);
  read_us_.reserve(1 << 16);
  overhead_us_.reserve(1 << 16);
  thr_entries_.reserve(1 << 14);
}

NrtRunner::~NrtRunner() {
  shutdown();
}

void NrtRunner::start() {
  const auto spec = [&](const char* suffix, int priority) {
    return ThreadSpec{cfg_.name + suffix, cfg_.core, sched_.control, priority};
  };
  // NCT first: its thread id is the counting target of a built-in workload. A built-in workload
  // runs on it (the work's class); for a command it only waits (the command gets the work's class).
  ThreadSpec nct_spec = spec("-nct", prio::kNct);
  if (builtin_) nct_spec.sched = sched_.work;
  if (!cfg_.foreign)
    nct_ = std::make_unique<RtThread>(
        nct_spec, [this] { nct_main(); }, on_error_);
  if (cfg_.foreign) {
    if (!group_)
      throw ContractError("nRT node " + cfg_.name + ": a foreign node needs set_group()");
  } else if (builtin_) {
    PmcTarget target;
    target.kind = PmcTarget::Kind::Thread;
    target.pid = nct_->tid();
    target.work = &work_;
    group_ = source_.open(cfg_.group_events, target);
  } else {
    auto pc = std::make_unique<ProcessCounters>(cfg_.group_events.size());
    process_counters_ = pc.get();
    group_ = std::move(pc);
  }
  if (cfg_.sampling == Sampling::Self)
    pmc_ = std::make_unique<RtThread>(
        spec("-pmc", prio::kPmc), [this] { pmc_main(); }, on_error_);
  thr_ = std::make_unique<RtThread>(
      spec("-thr", prio::kThr), [this] { thr_main(); }, on_error_);
  cfb_ = std::make_unique<RtThread>(
      spec("-cfb", prio::kCfb), [this] { cfb_main(); }, on_error_);
}

void NrtRunner::begin() {
  begun_.store(true, std::memory_order_release);
  nct_waker_.notify();
}

void NrtRunner::end_loop() {
  nct_stop_.store(true, std::memory_order_release);
  const std::uint64_t one = 1;
  ssize_t n = ::write(stop_fd_.get(), &one, sizeof one);
  (void)n;
  nct_waker_.notify();
}

void NrtRunner::shutdown() {
  if (shut_) return;
  shut_ = true;
  // Nominal first: the spinner sees a state other than THR and leaves its loop at once.
  state_.store(NodeState::Off, std::memory_order_release);
  stop_.store(true, std::memory_order_release);
  end_loop();
  for (Waker* w : {&cfb_waker_, &thr_waker_, &pmc_waker_, &nct_waker_})
    w->notify();
  for (auto* t : {&cfb_, &thr_, &pmc_, &nct_})
    if (*t) (*t)->join();
}

std::vector<SchedOutcome> NrtRunner::outcomes() const {
  std::vector<SchedOutcome> out;
  for (const auto* t : {&cfb_, &thr_, &pmc_, &nct_})
    if (*t) out.push_back((*t)->outcome());
  return out;
}

void NrtRunner::apply_effects(const NrtEffects& fx, TimeNs now, TimeNs& state_since) {
  if (fx.activation_delay_ns && cfg_.keep_measurements)
    activation_us_.push_back(ns_to_us(*fx.activation_delay_ns));
  if (fx.transition.changed()) {
    cfb_trace_.span(state_since - origin_, now - origin_, cfg_.core, &track_state_,
                    state_name(fx.transition.from));
    state_since = now;
    state_.store(fx.transition.to, std::memory_order_release);
  }
  // The zero-time timer; leaving THR wakes a freezer throttle, which sleeps while it holds.
  if (fx.throttle || fx.transition.from == NodeState::Thr) thr_waker_.notify();
  if (fx.baseline) {
    sample_now_.store(true, std::memory_order_release);  // a new activation: new baseline
    pmc_waker_.notify();
  } else if (fx.resume) {
    pmc_waker_.notify();  // a period that ended while throttled runs now
  }
}

// CFB: hands commands to the nRT engine and carries out its effects; runs the watchdog.
void NrtRunner::cfb_main() {
  TimeNs state_since = now_ns();
  driver_.heard(state_since);
  while (!stop_.load(std::memory_order_acquire)) {
    const auto epoch = cfb_waker_.epoch();
    ControlMsg m;
    bool got = false;
    while (control_.take(control_sub_, m)) {
      got = true;
      const TimeNs now = now_ns();
      driver_.heard(now);
      if (m.kind == ControlMsg::Kind::Keepalive) continue;
      cfb_trace_.instant(now - origin_, cfg_.core, &track_state_, to_string(m.command).data());
      apply_effects(driver_.command(now, m.command, m.t_cause), now, state_since);
    }
    if (stop_.load(std::memory_order_acquire)) break;
    if (got) continue;
    const auto deadline = driver_.watchdog_deadline();
    if (!cfb_waker_.wait(epoch, deadline.value_or(-1)) && deadline && now_ns() >= *deadline) {
      // The controller has been silent too long: back to nominal on our own.
      const TimeNs now = now_ns();
      const NrtEffects fx = driver_.watchdog(now);
      cfb_trace_.instant(now - origin_, cfg_.core, &track_state_, "watchdog: back to nominal");
      apply_effects(fx, now, state_since);
    }
  }
  const TimeNs now = now_ns();
  driver_.finish(now);
  cfb_trace_.span(state_since - origin_, now - origin_, cfg_.core, &track_state_,
                  state_name(driver_.state()));
  state_.store(NodeState::Off, std::memory_order_release);
}

// THR: entered through CFB's wake-up; holds the core (the idle loop that keeps it off the memory
// system, or the freezer) until the state leaves THR. Never holds after stop.
void NrtRunner::thr_main() {
  while (!stop_.load(std::memory_order_acquire)) {
    const auto epoch = thr_waker_.epoch();
    if (state_.load(std::memory_order_acquire) == NodeState::Thr) {
      const TimeNs enter = now_ns();
      if (cfg_.keep_measurements) thr_entries_.push_back(enter);
      throttler_->hold(
          [this] {
            return state_.load(std::memory_order_relaxed) == NodeState::Thr &&
                   !stop_.load(std::memory_order_relaxed);
          },
          thr_waker_);
      thr_trace_.span(enter - origin_, now_ns() - origin_, cfg_.core, &track_thr_, "THR");
      continue;
    }
    thr_waker_.wait(epoch, -1);
  }
}

void NrtRunner::take_sample(bool periodic, TimeNs& cpu_mark) {
  SampleMsg msg;
  msg.entity = cfg_.entity;
  msg.count = static_cast<std::uint8_t>(cfg_.metric_events);
  std::array<CounterValue, kMaxGroupEvents> all{};
  const TimeNs t0 = now_ns();
  group_->read(std::span(all.data(), cfg_.group_events.size()));
  const TimeNs t_read = now_ns();
  std::copy_n(all.begin(), cfg_.metric_events, msg.counters.begin());
  msg.t_published = now_ns();
  samples_.publish(sample_pub_, msg);
  const TimeNs t1 = now_ns();
  pmc_us_.push_back(ns_to_us(t1 - t0));
  read_us_.push_back(ns_to_us(t_read - t0));
  pmc_trace_.span(t0 - origin_, t1 - origin_, cfg_.core, &track_state_, "PMC");
  // Sampling overhead: the PMC thread's CPU time (wake-up, read, publish, going back to sleep)
  // per sampling period, averaged over kOverheadPeriods periods so that reading the thread
  // clock (a system call) costs little itself.
  if (!periodic) {
    cpu_mark = thread_cpu_ns();
    overhead_periods_ = 0;
  } else if (++overhead_periods_ == kOverheadPeriods) {
    const TimeNs cpu = thread_cpu_ns();
    overhead_us_.push_back(ns_to_us(cpu - cpu_mark) / kOverheadPeriods);
    cpu_mark = cpu;
    overhead_periods_ = 0;
  }
}

// PMC (self-sampling): a baseline sample at every ON, then one per sampling period while ON
// (a period that ended while throttled runs once when the node is ON again).
void NrtRunner::pmc_main() {
  SampleSchedule schedule(cfg_.sampling_period_ns);
  TimeNs cpu_mark = 0;
  while (!stop_.load(std::memory_order_acquire)) {
    const auto epoch = pmc_waker_.epoch();
    if (sample_now_.exchange(false, std::memory_order_acq_rel)) {
      take_sample(false, cpu_mark);
      schedule.restart(now_ns());
      continue;
    }
    if (state_.load(std::memory_order_acquire) == NodeState::On && schedule.next()) {
      if (schedule.elapsed(now_ns(), true)) {
        take_sample(true, cpu_mark);
        continue;
      }
      pmc_waker_.wait(epoch, *schedule.next());
      continue;
    }
    overhead_periods_ = 0;  // a period spent throttled or off is not sampling overhead
    cpu_mark = thread_cpu_ns();
    pmc_waker_.wait(epoch, -1);
    cpu_mark = thread_cpu_ns();
  }
}

void NrtRunner::nct_main() {
  while (!begun_.load(std::memory_order_acquire)) {
    const auto epoch = nct_waker_.epoch();
    if (stop_.load(std::memory_order_acquire)) return;
    if (begun_.load(std::memory_order_acquire)) break;
    nct_waker_.wait(epoch, -1);
  }
  if (stop_.load(std::memory_order_acquire)) return;
  if (!builtin_) return nct_command();
  if (cfg_.mode == NrtMode::Once) {
    const TimeNs t0 = now_ns();
    once_fraction_ = builtin_->run(nct_stop_, work_);
    once_time_us_ = ns_to_us(now_ns() - t0);
    once_done_.store(true, std::memory_order_release);
    engine_waker_.notify();
    return;
  }
  while (!nct_stop_.load(std::memory_order_acquire))
    builtin_->run(nct_stop_, work_);
}

// An external command: spawned pinned to the core at the NCT priority (below THR, so the throttle
// preempts it), counted per process, restarted in loop mode.
void NrtRunner::nct_command() {
  const auto& argv_json = workload_.doc.at("command");
  std::vector<std::string> argv;
  for (const auto& a : argv_json)
    argv.push_back(a.get<std::string>());
  const ThreadSpec spec{cfg_.name + "-cmd", cfg_.core, sched_.work, prio::kNct};
  while (!nct_stop_.load(std::memory_order_acquire)) {
    CommandProcess proc(argv, spec, workload_.doc.value("cwd", ""));
    // Before exec: everything it starts is born in the cgroup (a frozen one while throttled).
    if (cgroup_) cgroup_->add(proc.pid());
    PmcTarget target;
    target.kind = PmcTarget::Kind::Process;
    target.pid = proc.pid();
    target.enable_on_exec = true;
    process_counters_->next(source_.open(cfg_.group_events, target));
    const TimeNs t0 = now_ns();
    proc.start();
    if (!proc.wait(stop_fd_.get())) break;  // stopped: the destructor kills the group
    const TimeNs t1 = now_ns();
    if (!(WIFEXITED(proc.status()) && WEXITSTATUS(proc.status()) == 0))
      throw RunError("nRT node " + cfg_.name + ": command '" + argv[0] + "' ended with " +
                     describe_status(proc.status()));
    completed_.fetch_add(1, std::memory_order_acq_rel);
    if (cfg_.mode == NrtMode::Once) {
      once_time_us_ = ns_to_us(t1 - t0);
      once_fraction_ = 1.0;
      once_done_.store(true, std::memory_order_release);
      engine_waker_.notify();
      return;
    }
  }
}

}  // namespace rosguard::hw

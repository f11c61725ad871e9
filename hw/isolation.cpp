#include "hw/isolation.h"

#include <sys/eventfd.h>
#include <sys/wait.h>
#include <unistd.h>

#include <limits>
#include <optional>
#include <set>

#include "core/error.h"
#include "hw/common/clock.h"
#include "hw/common/sys.h"
#include "hw/nodes/messages.h"
#include "hw/safety_net.h"
#include "hw/wait.h"
#include "hw/workload/workload.h"

namespace rosguard::hw {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Idle spinners on the scenario's cores other than `busy` (RAII: stopped and joined on every
// path). They sit at the NCT priority and only execute pause instructions.
class IdleCores {
 public:
  IdleCores(const Scenario& s, int busy, SchedClass sched) {
    std::set<int> cores{s.nodes.controller_core};
    for (const auto& n : s.nodes.rt)
      cores.insert(n.core);
    for (const auto& n : s.nodes.nrt)
      cores.insert(n.core);
    cores.erase(busy);
    for (int c : cores)
      threads_.push_back(std::make_unique<RtThread>(
          ThreadSpec{"idle" + std::to_string(c), c, sched, prio::kNct}, [this] {
            while (!stop_.load(std::memory_order_relaxed))
              cpu_relax();
          }));
  }
  ~IdleCores() {
    stop_.store(true);
    for (auto& t : threads_)
      t->join();
  }
  IdleCores(const IdleCores&) = delete;
  IdleCores& operator=(const IdleCores&) = delete;
  std::vector<SchedOutcome> outcomes() const {
    std::vector<SchedOutcome> out;
    for (const auto& t : threads_)
      out.push_back(t->outcome());
    return out;
  }

 private:
  std::atomic<bool> stop_{false};
  std::vector<std::unique_ptr<RtThread>> threads_;
};

}  // namespace

SchedClass sched_of(const Scenario& s) {
  return s.hw.scheduler == SchedulerKind::Fifo ? SchedClass::Fifo : SchedClass::Other;
}

IsolationResult measure_alone(const Scenario& s, const MetricPlan& plan,
                              const PmcSourceRegistry& sources, const WorkloadInfo& w, int core,
                              RunContext& ctx) {
  auto source = sources.find(plan.source)->make();
  const bool counts = !plan.time_based && (!w.is_command() || source->counts_processes());
  const bool ipc = plan.source == "perf";
  Waker waker;
  ErrorBox errors(waker);
  std::atomic<bool> stop{false}, done{false};
  double time_us = 0.0, bytes = 0.0, cycles = 0.0, instructions = 0.0;
  double on_core = 1.0;  // the kept attempt's CPU time over its wall time (built-in kernels)
  int attempts = 1;
  Metric metric(plan.spec);
  std::unique_ptr<BuiltinWorkload> builtin;
  if (!w.is_command()) builtin = make_builtin_workload(w);
  Fd stop_fd(::eventfd(0, EFD_CLOEXEC));

  // The other cores of the scenario are held by idle spinners (no memory traffic) while the
  // workload runs alone, as they are held by the nodes' threads in a co-run: on a shared machine
  // other processes would otherwise run there and interfere with the isolation figure only.
  std::optional<ScopedSched> engine_sched(std::in_place,
                                          ThreadSpec{"", -1, sched_of(s), prio::kEngine});
  IdleCores idle(s, core, sched_of(s));
  report_sched(idle.outcomes(), ctx);

  const ThreadSpec spec{"isolation", core, sched_of(s), prio::kNct};
  RtThread thread(
      spec,
      [&] {
        struct Done {
          std::atomic<bool>& d;
          Waker& w;
          ~Done() {
            d.store(true, std::memory_order_release);
            w.notify();
          }
        } signal_done{done, waker};
        WorkCounters work;
        std::array<CounterValue, kMaxGroupEvents> v0{}, v1{}, i0{}, i1{};
        const std::size_t k = plan.metric_events;
        if (builtin) {
          PmcTarget target;
          target.work = &work;
          std::unique_ptr<CounterGroup> group, ipc_group;
          if (counts) group = source->open(plan.group_events, target);
          if (ipc) ipc_group = source->open({"cpu_cycles", "inst_retired"}, target);
          // A run that lost its core (on it less than kMinOnCore of the time) is taken again.
          for (;; ++attempts) {
            if (group) group->read(std::span(v0.data(), plan.group_events.size()));
            if (ipc_group) ipc_group->read(std::span(i0.data(), 2));
            const TimeNs c0 = thread_cpu_ns();
            const TimeNs t0 = now_ns();
            builtin->run(stop, work);
            const TimeNs t1 = now_ns();
            const TimeNs c1 = thread_cpu_ns();
            if (group) group->read(std::span(v1.data(), plan.group_events.size()));
            if (ipc_group) ipc_group->read(std::span(i1.data(), 2));
            time_us = ns_to_us(t1 - t0);
            on_core = t1 > t0 ? static_cast<double>(c1 - c0) / static_cast<double>(t1 - t0) : 1.0;
            if (on_core >= kMinOnCore || attempts == kOnCoreAttempts ||
                stop.load(std::memory_order_relaxed))
              break;
          }
        } else {
          std::vector<std::string> argv;
          for (const auto& a : w.doc.at("command"))
            argv.push_back(a.get<std::string>());
          CommandProcess proc(argv, ThreadSpec{"isolation-cmd", core, sched_of(s), prio::kNct},
                              w.doc.value("cwd", ""));
          PmcTarget target;
          target.kind = PmcTarget::Kind::Process;
          target.pid = proc.pid();
          target.enable_on_exec = true;
          std::unique_ptr<CounterGroup> group, ipc_group;
          if (counts) group = source->open(plan.group_events, target);
          if (ipc) ipc_group = source->open({"cpu_cycles", "inst_retired"}, target);
          const TimeNs t0 = now_ns();
          proc.start();
          if (!proc.wait(stop_fd.get())) return;
          const TimeNs t1 = now_ns();
          if (!(WIFEXITED(proc.status()) && WEXITSTATUS(proc.status()) == 0))
            throw RunError("isolation of '" + w.name + "': the command ended with " +
                           describe_status(proc.status()));
          if (group) group->read(std::span(v1.data(), plan.group_events.size()));
          if (ipc_group) ipc_group->read(std::span(i1.data(), 2));
          time_us = ns_to_us(t1 - t0);
        }
        if (counts) bytes = metric.delta_bytes(std::span(v0.data(), k), std::span(v1.data(), k));
        if (ipc) {
          cycles = scaled_delta(i0[0], i1[0], 64);
          instructions = scaled_delta(i0[1], i1[1], 64);
        }
      },
      errors.handler());
  report_sched({thread.outcome()}, ctx);
  const bool ok = wait_for(
      waker, [&] { return done.load(std::memory_order_acquire); },
      [&] { return ctx.stop_requested() || errors.failed(); });
  if (!ok) {
    stop.store(true);
    const std::uint64_t one = 1;
    ssize_t n = ::write(stop_fd.get(), &one, sizeof one);
    (void)n;
  }
  thread.join();
  if (errors.failed()) throw RunError("isolation of '" + w.name + "': " + errors.message());
  if (ctx.stop_requested()) throw Interrupted();
  if (on_core < kMinOnCore)
    ctx.fallback("isolation_off_core",
                 "an isolation run of '" + w.name + "' on core " + std::to_string(core) +
                     " was on its core less than " + std::to_string(std::lround(kMinOnCore * 100)) +
                     " % of its time in each of " + std::to_string(attempts) +
                     " attempts (RT throttling: sched_rt_runtime_us, or a higher priority); the "
                     "last is kept, so its slowdowns divide by a time that includes a wait");
  IsolationResult r;
  r.time_us = time_us;
  r.mbps = counts && time_us > 0 ? bytes / kBytesPerMb / (time_us / 1e6) : kNaN;
  r.ipc = ipc && cycles > 0 ? instructions / cycles : kNaN;
  return r;
}

}  // namespace rosguard::hw

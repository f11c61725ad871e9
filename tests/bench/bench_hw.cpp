// hw backend micro-benchmarks: the PMC read (a 4-event perf software group, the instrumented
// source), a topic wake-up round trip between two SCHED_FIFO threads on two cores, and the host's
// floor for self-sampling (a bare periodic thread, no node code).
// Targets on the 2-vCPU VM (issue 4): 4-event software group read median <= 2 us.
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <atomic>
#include <optional>
#include <thread>

#include "hw/common/clock.h"
#include "hw/common/sys.h"
#include "hw/executor/executor.h"
#include "hw/pmc_source/pmc_source.h"
#include "hw/topic/dds_topic.h"
#include "hw/topic/topic.h"
#include "hw/workload/work_counters.h"

namespace {

using namespace rosguard;
using namespace rosguard::hw;

// Reading this thread's own 4-event software group (warm caches: the best case).
void BM_SoftwareGroupRead_Self(benchmark::State& state) {
  auto src = make_software_source();
  if (src->unavailable_reason()) {
    state.SkipWithError("perf software events unavailable");
    return;
  }
  auto g = src->open(software_group_events(), PmcTarget{});
  CounterValue v[4];
  for (auto _ : state) {
    g->read(v);
    benchmark::DoNotOptimize(v);
  }
}
BENCHMARK(BM_SoftwareGroupRead_Self);

// Reading the group of another thread that is blocked (as the NCT thread is when its PMC
// callback preempts it on the same core).
void BM_SoftwareGroupRead_BlockedThread(benchmark::State& state) {
  auto src = make_software_source();
  if (src->unavailable_reason()) {
    state.SkipWithError("perf software events unavailable");
    return;
  }
  std::atomic<pid_t> tid{0};
  Waker done;
  std::atomic<bool> stop{false};
  std::thread other([&] {
    tid = current_tid();
    while (!stop.load()) {
      const auto e = done.epoch();
      if (stop.load()) break;
      done.wait(e, -1);
    }
  });
  while (tid.load() == 0)
    std::this_thread::yield();
  PmcTarget t;
  t.kind = PmcTarget::Kind::Thread;
  t.pid = tid;
  auto g = src->open(software_group_events(), t);
  CounterValue v[4];
  for (auto _ : state) {
    g->read(v);
    benchmark::DoNotOptimize(v);
  }
  stop = true;
  done.notify();
  other.join();
}
BENCHMARK(BM_SoftwareGroupRead_BlockedThread);

void BM_InstrumentedRead(benchmark::State& state) {
  auto src = make_instrumented_source();
  WorkCounters work;
  PmcTarget t;
  t.work = &work;
  auto g = src->open({"l2d_cache_refill", "l2d_cache_wb"}, t);
  CounterValue v[2];
  for (auto _ : state) {
    g->read(v);
    benchmark::DoNotOptimize(v);
  }
}
BENCHMARK(BM_InstrumentedRead);

// The body of a thread that keeps its core busy, as the NCT thread does, without memory traffic.
auto spin_until(const std::atomic<bool>& stop) {
  return [&stop] {
    while (!stop.load(std::memory_order_relaxed))
      cpu_relax();
  };
}

// Publish -> the subscriber on the other core wakes (futex) -> it publishes back -> we wake.
// Manual time: one round trip, so the one-way wake-up is about half of it. Arg busy 1: the
// subscriber's core runs a spinner at the NCT priority meanwhile, as the nRT core does when the
// controller publishes THR to it (external sampling): the wake-up must then interrupt a running
// core, which on a VM can cost far more than waking an idle one. Arg dds 1: the topics are the
// DDS transport's (Cyclone DDS, ROS 2 names, one participant: local delivery) instead of the
// in-process rings; the messages are control commands either way.
void BM_TopicRoundTrip_TwoCores(benchmark::State& state) {
  const auto cpus = usable_cpus();
  if (cpus.size() < 2) {
    state.SkipWithError("needs two CPUs");
    return;
  }
  std::unique_ptr<dds::Participant> participant;
  std::unique_ptr<Topic<ControlMsg>> ping, pong;
  if (state.range(1) != 0) {
    participant = std::make_unique<dds::Participant>();
    const std::string ns = "/rosguard_bench_" + std::to_string(::getpid());
    ping = std::make_unique<DdsTopic<ControlMsg>>(*participant, ns, std::vector<DdsSlot>{{"ping"}});
    pong = std::make_unique<DdsTopic<ControlMsg>>(*participant, ns, std::vector<DdsSlot>{{"pong"}});
  } else {
    ping = std::make_unique<InprocTopic<ControlMsg>>();
    pong = std::make_unique<InprocTopic<ControlMsg>>();
  }
  Waker ping_waker, pong_waker;
  const auto ping_pub = ping->add_publisher();
  const auto ping_sub = ping->subscribe(ping_waker);
  const auto pong_pub = pong->add_publisher();
  const auto pong_sub = pong->subscribe(pong_waker);
  std::atomic<bool> stop{false};
  std::optional<RtThread> spinner;
  if (state.range(0) != 0)
    spinner.emplace(ThreadSpec{"spinner", cpus[1], SchedClass::Fifo, prio::kNct}, spin_until(stop));
  RtThread echo(ThreadSpec{"echo", cpus[1], SchedClass::Fifo, prio::kCfb}, [&] {
    while (!stop.load()) {
      const auto e = ping_waker.epoch();
      ControlMsg m;
      bool got = false;
      while (ping->take(ping_sub, m)) {
        pong->publish(pong_pub, m);
        got = true;
      }
      if (!got) ping_waker.wait(e, now_ns() + 100 * kNsPerMs);
    }
  });
  ScopedSched me(ThreadSpec{"bench", cpus[0], SchedClass::Fifo, prio::kController});
  for (auto _ : state) {
    const TimeNs t0 = now_ns();
    const auto e = pong_waker.epoch();
    ping->publish(ping_pub, {ControlMsg::Kind::Command, Command::Thr, t0});
    ControlMsg back;
    while (!pong->take(pong_sub, back))
      pong_waker.wait(e, now_ns() + 100 * kNsPerMs);
    state.SetIterationTime(static_cast<double>(now_ns() - t0) / 1e9);
  }
  stop = true;
  ping_waker.notify();
}
BENCHMARK(BM_TopicRoundTrip_TwoCores)
    ->ArgNames({"busy", "dds"})
    ->Args({0, 0})
    ->Args({1, 0})
    ->Args({0, 1})
    ->Args({1, 1})
    ->UseManualTime()
    ->Iterations(2000);

// The host's floor for self-sampling at 1 ms: a bare SCHED_FIFO thread at the PMC priority on the
// nRT core, preempting a spinner at the NCT priority, wakes at an absolute deadline every period
// and goes back to sleep (the Waker's futex, as the PMC thread does). Arg 0: nothing else; arg 1:
// plus one notify() of a thread sleeping on the other core (the publish to the controller); arg
// 2: of a thread sleeping on the same core. Counter cpu_us_per_period: the sampler's CPU time per
// period, i.e. what the spinner loses to it. rosguard's `sampling_overhead` (PMC thread CPU time
// per period) cannot be below arg 1 on the same host: it adds only the group read to it.
void BM_HostFloor_PeriodicSampler(benchmark::State& state) {
  const auto cpus = usable_cpus();
  if (cpus.size() < 2) {
    state.SkipWithError("needs two CPUs");
    return;
  }
  const int nrt_core = cpus[1];
  const auto publish = state.range(0);
  std::atomic<bool> stop{false};
  Waker sleeper_waker;
  RtThread spinner(ThreadSpec{"spinner", nrt_core, SchedClass::Fifo, prio::kNct}, spin_until(stop));
  std::optional<RtThread> sleeper;
  if (publish != 0)
    sleeper.emplace(ThreadSpec{"sleeper", publish == 1 ? cpus[0] : nrt_core, SchedClass::Fifo,
                               prio::kController},
                    [&] {
                      while (!stop.load()) {
                        const auto e = sleeper_waker.epoch();
                        if (stop.load()) break;
                        sleeper_waker.wait(e, -1);
                      }
                    });
  Waker timer;  // nobody notifies it: the sampler sleeps until its deadline
  TimeNs cpu = 0;
  {
    ScopedSched me(ThreadSpec{"sampler", nrt_core, SchedClass::Fifo, prio::kPmc});
    TimeNs next = now_ns() + kNsPerMs;
    const TimeNs cpu0 = thread_cpu_ns();
    for (auto _ : state) {
      timer.wait(timer.epoch(), next);
      next += kNsPerMs;
      if (publish != 0) sleeper_waker.notify();
    }
    cpu = thread_cpu_ns() - cpu0;
  }
  stop = true;
  sleeper_waker.notify();
  state.counters["cpu_us_per_period"] =
      static_cast<double>(cpu) / 1e3 / static_cast<double>(state.iterations());
}
BENCHMARK(BM_HostFloor_PeriodicSampler)
    ->ArgName("publish")
    ->Arg(0)
    ->Arg(1)
    ->Arg(2)
    ->Iterations(1000)
    ->Unit(benchmark::kMillisecond);

}  // namespace

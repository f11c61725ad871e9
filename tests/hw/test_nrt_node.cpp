// The nRT node archetype driven by hand through its control topic: THR throttles the workload
// (NCT stops progressing), REPLENISH releases it, the watchdog brings a node whose controller went
// silent back to nominal, and shutdown leaves nothing spinning.
#include <catch2/catch.hpp>
#include <thread>

#include "hw/common/clock.h"
#include "hw/common/sys.h"
#include "hw/nodes/nrt_node.h"

using namespace rosguard;
using namespace rosguard::hw;

namespace {

struct Rig {
  InprocTopic<ControlMsg> control;
  InprocTopic<SampleMsg> samples;
  Waker engine, sample_waker;
  std::size_t pub = 0, sample_sub = 0;
  std::unique_ptr<PmcSource> source = make_instrumented_source();
  WorkloadInfo workload{
      "r",
      "inline",
      {{"name", "r"},
       {"hw", {{"kernel", "bandwidth_read"}, {"working_set_kb", 256}, {"passes", 1}}}}};
  std::unique_ptr<NrtRunner> node;

  explicit Rig(Sampling sampling, TimeNs watchdog_ns) {
    NrtConfig c;
    c.name = "nrt0";
    c.core = usable_cpus().back();
    c.sampling = sampling;
    c.sampling_period_ns = kNsPerMs;
    c.watchdog_ns = watchdog_ns;
    c.mode = NrtMode::Loop;
    c.group_events = {"l2d_cache_refill", "l2d_cache_wb"};
    c.metric_events = 2;
    node = std::make_unique<NrtRunner>(c, workload, *source, control, samples, engine,
                                       RtThread::ErrorHandler{}, now_ns());
    pub = control.add_publisher();
    sample_sub = samples.subscribe(sample_waker);
    node->start();
    node->begin();
  }
  void send(Command c) { control.publish(pub, {ControlMsg::Kind::Command, c, now_ns()}); }
  bool wait_state(NodeState s, TimeNs timeout) {
    const TimeNs end = now_ns() + timeout;
    while (now_ns() < end) {
      if (node->state() == s) return true;
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    return node->state() == s;
  }
  std::uint64_t lines() const { return node->work().lines_read.load(); }
};

}  // namespace

TEST_CASE("THR stops the workload and REPLENISH releases it", "[hw][nrt]") {
  Rig rig(Sampling::External, 10 * kNsPerS);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  CHECK(rig.lines() > 0);  // nominal: NCT runs
  rig.send(Command::On);
  REQUIRE(rig.wait_state(NodeState::On, kNsPerS));
  rig.send(Command::Thr);
  REQUIRE(rig.wait_state(NodeState::Thr, kNsPerS));
  std::this_thread::sleep_for(std::chrono::milliseconds(5));
  const auto frozen = rig.lines();
  std::this_thread::sleep_for(std::chrono::milliseconds(30));
  // The THR spinner holds the core: NCT makes no progress (SCHED_FIFO; a fallback may leak).
  if (realtime_threads().empty())
    WARN("no SCHED_FIFO here: the throttle is approximate");
  else
    CHECK(rig.lines() == frozen);
  rig.send(Command::Replenish);
  REQUIRE(rig.wait_state(NodeState::On, kNsPerS));
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  CHECK(rig.lines() > frozen);
  rig.send(Command::Off);
  REQUIRE(rig.wait_state(NodeState::Off, kNsPerS));
  rig.node->shutdown();
  CHECK(rig.node->throttles() == 1);
  CHECK(rig.node->throttled_ns() > 25 * kNsPerMs);
  REQUIRE(rig.node->activation_delays_us().size() == 1);
  CHECK(rig.node->activation_delays_us()[0] < 10'000.0);
  CHECK(realtime_threads().empty());
}

TEST_CASE("watchdog: a silent controller leaves the node throttled at most watchdog_ms",
          "[hw][nrt][safety]") {
  const TimeNs watchdog = 50 * kNsPerMs;
  Rig rig(Sampling::External, watchdog);
  rig.send(Command::On);
  rig.send(Command::Thr);
  REQUIRE(rig.wait_state(NodeState::Thr, kNsPerS));
  const TimeNs silent_since = now_ns();  // the controller says nothing from here on
  REQUIRE(rig.wait_state(NodeState::Off, 5 * watchdog));
  const TimeNs back = now_ns() - silent_since;
  WARN("watchdog brought the node back to nominal after " << back / 1000 << " us (watchdog "
                                                          << watchdog / 1000 << " us)");
  CHECK(back <= watchdog + 20 * kNsPerMs);
  const auto lines = rig.lines();
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  CHECK(rig.lines() > lines);  // nominal work resumed
  rig.node->shutdown();
  CHECK(rig.node->watchdog_fired() == 1);
  CHECK(realtime_threads().empty());
}

TEST_CASE("keepalives hold the watchdog off", "[hw][nrt][safety]") {
  const TimeNs watchdog = 30 * kNsPerMs;
  Rig rig(Sampling::External, watchdog);
  rig.send(Command::On);
  REQUIRE(rig.wait_state(NodeState::On, kNsPerS));
  for (int i = 0; i < 10; ++i) {
    rig.control.publish(rig.pub, {ControlMsg::Kind::Keepalive, Command::On, 0});
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  CHECK(rig.node->state() == NodeState::On);
  rig.node->shutdown();
  CHECK(rig.node->watchdog_fired() == 0);
}

TEST_CASE("self-sampling: a baseline sample at ON, then one per period", "[hw][nrt]") {
  Rig rig(Sampling::Self, 10 * kNsPerS);
  const TimeNs on = now_ns();
  rig.send(Command::On);
  std::this_thread::sleep_for(std::chrono::milliseconds(30));
  rig.send(Command::Off);
  REQUIRE(rig.wait_state(NodeState::Off, kNsPerS));
  // The node sampled for at most this long: the 30 ms sleep overruns on a loaded machine (seen:
  // 36 samples beside a spinner and a build).
  const TimeNs on_for = now_ns() - on;
  std::size_t n = 0;
  SampleMsg m;
  std::uint64_t last = 0;
  while (rig.samples.take(rig.sample_sub, m)) {
    CHECK(m.count == 2);
    CHECK(m.counters[0].value >= last);
    last = m.counters[0].value;
    ++n;
  }
  INFO("ON for at most " << on_for / 1000 << " us");
  CHECK(n >= 10);  // 30 ms at 1 ms (a loaded VM may miss some)
  // The baseline, one per whole period, and one more at OFF at most.
  CHECK(n <= static_cast<std::size_t>(on_for / kNsPerMs) + 2);
  rig.node->shutdown();
  CHECK(rig.node->pmc_callbacks_us().size() == n);
}

TEST_CASE("shutdown while throttled: nominal, joined, nothing left spinning", "[hw][nrt][safety]") {
  Rig rig(Sampling::Self, 10 * kNsPerS);
  rig.send(Command::On);
  rig.send(Command::Thr);
  REQUIRE(rig.wait_state(NodeState::Thr, kNsPerS));
  const TimeNs t0 = now_ns();
  rig.node->shutdown();
  CHECK(now_ns() - t0 < 100 * kNsPerMs);
  CHECK(rig.node->state() == NodeState::Off);
  CHECK(realtime_threads().empty());
}

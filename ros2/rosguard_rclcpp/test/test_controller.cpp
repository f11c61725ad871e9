// The controller node with an RT node's RtJob and an nRT node's NrtGuard, in one process over
// rclcpp topics: RT jobs reach the controller; an over-budget nRT node is held to its budget.
#include <catch2/catch.hpp>

#include "../src/stream_node.hpp"
#include "common.hpp"
#include "rosguard_rclcpp/controller.hpp"
#include "rosguard_rclcpp/nrt_guard.hpp"
#include "rosguard_rclcpp/rt_job.hpp"
#include "rosguard_rclcpp/workload.hpp"

namespace rosguard_rclcpp::test {
namespace {

namespace hw = rosguard::hw;

ControllerOptions controller_options(const std::string& ns, const Cores& cores) {
  ControllerOptions o;
  o.ns = ns;
  o.core = cores.control;
  o.rt_nodes = {"rt"};
  o.nrt_nodes = {"stream"};
  o.policy = "interval";
  o.sampling = rosguard::Sampling::Self;
  o.sampling_period_us = 1000;
  o.regulation_period_us = 5000;
  o.threshold_pct = 20.0;
  o.reference_mbps = 10000.0;
  return o;
}

}  // namespace

TEST_CASE("an RT job's start and end reach the controller") {
  const auto cores = test_cores();
  if (!cores.two()) {
    WARN("SKIPPED: needs two usable CPUs");
    return;
  }
  const auto ns = unique_ns("rtjob");
  auto cnode = std::make_shared<rclcpp::Node>("rosguard_controller", ns.substr(1));
  Controller controller(cnode, controller_options(ns, cores));
  controller.start();
  auto rnode = std::make_shared<rclcpp::Node>("rt", ns.substr(1));
  RtJob job(*rnode, "rt", ns);
  REQUIRE(job.topic() == ns + "/rosguard/rt/active");
  REQUIRE(wait_for([&] { return rnode->count_subscribers(job.topic()) > 0; },
                   std::chrono::seconds(10)));
  constexpr int kJobs = 5;
  for (int i = 0; i < kJobs; ++i) {
    auto scope = job.scope();
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  REQUIRE(wait_for([&] { return controller.counts().rt_ends == kJobs; }, std::chrono::seconds(10)));
  controller.stop();
  const auto c = controller.counts();
  CHECK(c.rt_starts == kJobs);
  CHECK(c.rt_ends == kJobs);
  CHECK(c.activations == kJobs);
  CHECK(controller.totals().activations == kJobs);
  // Each activation lasted about its job's 20 ms (the messages' transit aside).
  const double active_ms = static_cast<double>(controller.totals().active_ns) / 1e6;
  CHECK(active_ms > kJobs * 10.0);
  CHECK(active_ms < kJobs * 200.0);
}

TEST_CASE("an over-budget nRT node is held to its budget within the policy's bound") {
  const auto cores = test_cores();
  if (!cores.two()) {
    WARN("SKIPPED: needs two usable CPUs");
    return;
  }
  const auto ns = unique_ns("budget");
  StreamNode stream(ns, cores.nrt, "instrumented");
  // The node's own rate, unregulated, on this host now (lines per ns).
  REQUIRE(wait_for([&] { return stream.lines() > 0; }, std::chrono::seconds(10)));
  const auto rate_of = [&](std::chrono::milliseconds d) {
    const double l0 = stream.lines();
    const auto t0 = hw::now_ns();
    std::this_thread::sleep_for(d);
    return (stream.lines() - l0) / static_cast<double>(hw::now_ns() - t0);
  };
  const double rate = rate_of(std::chrono::milliseconds(300));
  REQUIRE(rate > 0.0);
  const double rate_mbps = rate * 64.0 * 1e9 / rosguard::kBytesPerMb;

  auto opts = controller_options(ns, cores);
  opts.reference_mbps = rate_mbps;  // 20 % of what the node streams alone
  auto cnode = std::make_shared<rclcpp::Node>("rosguard_controller", ns.substr(1));
  Controller controller(cnode, opts);
  // The window accounting reads the node's counters themselves (not its samples).
  controller.set_counters(0, stream.guard->counters());
  controller.start();
  auto rnode = std::make_shared<rclcpp::Node>("rt", ns.substr(1));
  RtJob job(*rnode, "rt", ns);
  REQUIRE(wait_for([&] { return rnode->count_subscribers(job.topic()) > 0; },
                   std::chrono::seconds(10)));
  REQUIRE(wait_for(
      [&] { return cnode->count_subscribers(rosguard_topic(ns, "stream", "command")) > 0; },
      std::chrono::seconds(10)));
  {
    auto scope = job.scope();
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
  REQUIRE(wait_for([&] { return controller.counts().rt_ends == 1; }, std::chrono::seconds(10)));
  controller.stop();
  stream.guard->stop();

  const auto s = stream.guard->stats();
  const auto c = controller.counts();
  REQUIRE(c.thr > 0);
  const double budget = 0.20 * rate * 5e6 * 64.0;  // bytes per 5 ms window
  // The policy's bound: a window's budget, plus what the node can stream at its own rate from the
  // sample before the one that crossed the budget until THR holds the core: one sampling period,
  // the sample's transit to the controller and the command's back to THR (the largest of this
  // run), with a quarter more rate for a host that ran the node faster during the run.
  const double lat = quantile(controller.sample_latencies_us(), 1.0);
  const double act = quantile(s.activation_delays_us, 1.0);
  const double bound = budget + 1.25 * rate * 64.0 * (1e6 + (lat + act) * 1e3);
  std::size_t complete = 0, over = 0;
  double worst = 0.0, sum = 0.0;
  for (const auto& w : controller.windows()) {
    if (!w.complete) continue;
    ++complete;
    sum += w.bytes;
    worst = std::max(worst, w.bytes);
    if (w.bytes > bound) ++over;
  }
  WARN("nRT node alone " << rate_mbps << " MB/s; budget " << budget / 1e6
                         << " MB per 5 ms window, bound " << bound / 1e6
                         << " MB (sample transit max " << lat << " us, activation max " << act
                         << " us); " << complete << " windows, mean " << sum / complete / 1e6
                         << " MB, worst " << worst / 1e6 << " MB; THR " << c.thr);
  REQUIRE(complete >= 50);
  CHECK(over == 0);
  // Regulation did hold it back: the mean window well below what the node streams alone.
  CHECK(sum / complete < 0.6 * rate * 5e6 * 64.0);
}

}  // namespace rosguard_rclcpp::test

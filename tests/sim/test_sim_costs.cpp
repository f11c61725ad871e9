// Costs by placement: a platform may give the latency of a message between two nodes on one core
// (local_message_latency_us) apart from the one between cores, and the cost of a controller
// callback woken on its own core (controller_callback_local_us) apart from one woken from another.
#include <algorithm>
#include <catch2/catch.hpp>
#include <fstream>
#include <vector>

#include "platform/sim_platform.h"
#include "sim_test_util.h"

using namespace rosguard;
using namespace rosguard::sim;

namespace {

nlohmann::json vm_platform() {
  std::ifstream in(test::source_dir() / "scenarios/platforms/vm-2core.json");
  return nlohmann::json::parse(in);
}

}  // namespace

TEST_CASE("a same-core message takes the local latency where the platform gives one",
          "[sim][costs]") {
  nlohmann::json doc = vm_platform();
  doc["costs"]["local_message_latency_us"] = {{"dist", "constant"}, {"value_us", 2.5}};
  doc["costs"]["message_latency_us"] = {{"dist", "constant"}, {"value_us", 20.0}};
  const SimPlatform p = parse_sim_platform(build_platform(doc, "vm-2core.json"));
  REQUIRE(p.costs.local_message_latency.has_value());
  CHECK(p.costs.message_latency_between(1, 1).mean() == Approx(2.5));
  CHECK(p.costs.message_latency_between(0, 1).mean() == Approx(20.0));

  doc["costs"].erase("local_message_latency_us");
  const SimPlatform without = parse_sim_platform(build_platform(doc, "vm-2core.json"));
  CHECK_FALSE(without.costs.local_message_latency.has_value());
  CHECK(without.costs.message_latency_between(1, 1).mean() == Approx(20.0));
}

namespace {

// The samples of `kind` (activation_delay, pmc_callback, ...) of one interval point on a copy of
// vm-2core with constant costs: the nRT node on core 1, the controller on `controller_core`.
std::vector<double> samples(nlohmann::json costs, const std::string& sampling, int controller_core,
                            const std::string& kind = "activation_delay") {
  nlohmann::json plat = vm_platform();
  for (auto& [k, v] : costs.items())
    plat["costs"][k] = {{"dist", "constant"}, {"value_us", v}, {"source", "the test"}};
  test::TempDir dir;
  const auto file = dir.path() / "platform.json";
  std::ofstream(file) << plat.dump();
  const nlohmann::json doc = {
      {"name", "chain"},
      {"platform", file.string()},
      {"nodes",
       {{"controller", {{"core", controller_core}}},
        {"rt", {{{"name", "rt0"}, {"core", 0}, {"workload", "bandwidth_read"}, {"iterations", 2}}}},
        {"nrt", {{{"name", "nrt0"}, {"core", 1}, {"workload", "bandwidth_read"}}}}}},
      {"regulation",
       {{"policy", "interval"},
        {"sampling", sampling},
        {"sampling_period_us", 250},
        {"regulation_period_us", 5000},
        {"threshold_pct", 5}}}};
  const auto rep = test::run_point_report(test::load_points_json(doc, dir.path()).at(0));
  std::vector<double> out;
  for (const auto& o : rep["samples"])
    if (o[0] == kind) out.push_back(o[1].get<double>());
  return out;
}

double median(std::vector<double> v) {
  REQUIRE_FALSE(v.empty());
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

TEST_CASE(
    "a controller woken on its own core takes controller_callback_local_us, and a command to a "
    "node beside it is taken as that callback ends",
    "[sim][costs]") {
  const nlohmann::json costs = {{"external_read_us", 1.0},         {"controller_callback_us", 20.0},
                                {"local_message_latency_us", 5.0}, {"message_latency_us", 30.0},
                                {"throttle_activation_us", 2.0},   {"publish_us", 4.0},
                                {"pmc_callback_us", 0.5}};
  // External sampling, the controller beside the nRT node: from the read to THR entered.
  nlohmann::json with_local = costs;
  with_local["controller_callback_local_us"] = 3.0;
  // callback_local 3 + no message + CFB 2 (a queued callback now and then adds to some)
  CHECK(median(samples(with_local, "external", 1)) == Approx(5.0).margin(0.05));
  // Without it: callback 20 + local message 5 + CFB 2.
  CHECK(median(samples(costs, "external", 1)) == Approx(27.0).margin(0.05));
  // Self-sampling from another core: the callback is a remote one either way, and between cores
  // the sample leaves as its publish ends: from the publication, publish 4 + message 30 +
  // callback 20 + message 30 + CFB 2.
  CHECK(median(samples(with_local, "self", 0)) == Approx(86.0).margin(0.05));
  CHECK(median(samples(costs, "self", 0)) == Approx(86.0).margin(0.05));
  // Self-sampling beside the controller: the sample arrives local_message_latency 5 after the
  // publish starts, at the earliest as the publish ends (4), then callback_local 3 and CFB 2.
  CHECK(median(samples(with_local, "self", 1)) == Approx(10.0).margin(0.05));
}

TEST_CASE("a timer-driven sample costs its core timer_wakeup_us before the callback",
          "[sim][costs]") {
  nlohmann::json costs = {{"pmc_callback_us", 0.5}, {"publish_us", 4.0}};
  // Self-sampling: every sample but the baseline at ON is timer-driven.
  CHECK(median(samples(costs, "self", 0, "pmc_callback")) == Approx(0.5).margin(0.01));
  costs["timer_wakeup_us"] = 7.0;
  CHECK(median(samples(costs, "self", 0, "pmc_callback")) == Approx(7.5).margin(0.01));
  // External sampling: the controller's read follows its timer's wake-up; the read itself, from
  // which the activation delay runs, is unchanged.
  costs["external_read_us"] = 1.0;
  CHECK(median(samples(costs, "external", 1, "pmc_callback")) == Approx(1.0).margin(0.01));
}

TEST_CASE("a callback that preempts a running workload costs it preemption_us more",
          "[sim][costs]") {
  // The controller on the RT node's core, reading the nRT counters every 250 us: each read
  // preempts the RT job.
  const auto rt_time = [](double preemption_us) {
    nlohmann::json plat = vm_platform();
    for (const auto& [k, v] : {std::pair<const char*, double>{"timer_wakeup_us", 3.0},
                               {"external_read_us", 1.0},
                               {"controller_callback_us", 5.0},
                               {"controller_callback_local_us", 5.0}})
      plat["costs"][k] = {{"dist", "constant"}, {"value_us", v}, {"source", "the test"}};
    if (preemption_us > 0)
      plat["costs"]["preemption_us"] = {
          {"dist", "constant"}, {"value_us", preemption_us}, {"source", "the test"}};
    test::TempDir dir;
    const auto file = dir.path() / "platform.json";
    std::ofstream(file) << plat.dump();
    const nlohmann::json doc = {
        {"name", "preempted"},
        {"platform", file.string()},
        {"nodes",
         {{"controller", {{"core", 0}}},
          {"rt", {{{"name", "rt0"}, {"core", 0}, {"workload", "bandwidth_read"}}}},
          {"nrt", {{{"name", "nrt0"}, {"core", 1}, {"workload", "bandwidth_read"}}}}}},
        {"regulation",
         {{"policy", "interval"},
          {"sampling", "external"},
          {"sampling_period_us", 250},
          {"regulation_period_us", 5000},
          {"threshold_pct", 50}}}};
    const auto rep = test::run_point_report(test::load_points_json(doc, dir.path()).at(0));
    return rep["rt"][0]["time_us"].get<double>();
  };
  const double without = rt_time(0.0), with = rt_time(20.0);
  INFO("RT job " << without << " us without, " << with << " us with 20 us per preemption");
  // About one preemption per read (every 250 us of the longer job; a period boundary every 5 ms
  // adds a callback that mostly follows a read), each 20 us of the job's time.
  const double preemptions = (with - without) / 20.0;
  CHECK(preemptions == Approx(with / 250.0).epsilon(0.1));
  // Nothing else changes: without the cost, a platform runs as before it existed.
  CHECK(rt_time(0.0) == without);
}

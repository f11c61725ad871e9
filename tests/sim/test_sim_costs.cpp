// Message latencies by placement: a platform may give the latency of a message between two
// nodes on one core (local_message_latency_us) apart from the one between cores.
#include <catch2/catch.hpp>
#include <fstream>

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

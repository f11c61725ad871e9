// Calibration: an isolation run of each of the seven paper workloads on orin-agx reproduces the
// paper's Table 1 (average IPC and Eq. 1 bandwidth), each within 3 %, and lasts between about
// 50 ms and 1 s of simulated time.
#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "sim_test_util.h"

using namespace rosguard;

namespace {

struct Table1 {
  const char* name;
  double ipc;
  double mbps;
};

// The paper's Table 1, written out here on purpose (not read from the workload files).
constexpr Table1 kTable1[] = {
    {"bandwidth_read", 1.07, 26271.74},
    {"bandwidth_write", 1.61, 25519.15},
    {"disparity", 0.83, 1517.16},
    {"mser", 2.16, 3722.43},
    {"sift", 0.58, 232.15},
    {"stitch", 0.69, 713.08},
    {"tracking", 3.89, 393.43},
};

void check_isolation(const char* name, int core) {
  const Table1* ref = nullptr;
  for (const auto& t : kTable1)
    if (std::string(t.name) == name) ref = &t;
  REQUIRE(ref != nullptr);
  test::TempDir dir;
  const nlohmann::json doc = {{"name", std::string("calibration-") + name},
                              {"nodes",
                               {{"controller", {{"core", 0}}},
                                {"rt", {{{"name", "rt0"}, {"core", core}, {"workload", name}}}}}}};
  const auto points = test::load_points_json(doc, dir.path());
  const auto& rt = points.at(0).nodes.rt.at(0);
  const IsolationResult iso = test::isolation(points[0], rt.workload, rt.core);
  INFO(name << " on core " << core << ": IPC " << iso.ipc << " (Table 1: " << ref->ipc << "), "
            << iso.mbps << " MB/s (Table 1: " << ref->mbps << "), " << iso.time_us / 1e3 << " ms");
  CHECK(iso.ipc == Approx(ref->ipc).epsilon(0.03));
  CHECK(iso.mbps == Approx(ref->mbps).epsilon(0.03));
  CHECK(iso.time_us >= 45e3);
  CHECK(iso.time_us <= 1e6);
}

}  // namespace

TEST_CASE("calibration: bandwidth_read in isolation matches Table 1", "[sim][calibration]") {
  check_isolation("bandwidth_read", 2);
}
TEST_CASE("calibration: bandwidth_write in isolation matches Table 1", "[sim][calibration]") {
  check_isolation("bandwidth_write", 2);
}
TEST_CASE("calibration: disparity in isolation matches Table 1", "[sim][calibration]") {
  check_isolation("disparity", 2);
}
TEST_CASE("calibration: mser in isolation matches Table 1", "[sim][calibration]") {
  check_isolation("mser", 1);
}
TEST_CASE("calibration: sift in isolation matches Table 1", "[sim][calibration]") {
  check_isolation("sift", 2);
}
TEST_CASE("calibration: stitch in isolation matches Table 1", "[sim][calibration]") {
  check_isolation("stitch", 2);
}
TEST_CASE("calibration: tracking in isolation matches Table 1", "[sim][calibration]") {
  check_isolation("tracking", 2);
}
TEST_CASE("calibration: isolation does not depend on the core or cluster", "[sim][calibration]") {
  check_isolation("mser", 9);
}

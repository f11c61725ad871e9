// The calibration measurements contract (model/calibration/measurements.h): JSON round trip and
// the errors from_json gives for a document that does not match.
#include <catch2/catch.hpp>

#include "calibration/measurements.h"
#include "core/error.h"

using namespace rosguard;
using namespace rosguard::calibration;
using json = nlohmann::json;

namespace {

Measurements sample() {
  Measurements m;
  m.host = {"vm1", "AMD EPYC", 2, 1, 2, 2445.4, 64, 32, 512, 32768, "2026-11-23T14:00:00Z"};
  m.runs.push_back({"bandwidth_read", 2048, {}, 0.95, 0.012, 7});
  m.runs.push_back({"latency", 65536, {{"bandwidth_write", 131072}}, 98.5, 0.03, 5});
  m.costs_us["publish"] = {12.5, 13.0, 17.25};
  m.costs_us["pmc_callback"] = {0.1};
  m.wall_s = 171.5;
  return m;
}

}  // namespace

TEST_CASE("calibration measurements survive a JSON round trip", "[calibration]") {
  const Measurements m = sample();
  json j;
  to_json(j, m);
  // Through text too: what calibration.json holds.
  const Measurements r = measurements_from_json(json::parse(j.dump()), "c.json");
  CHECK(r.host.hostname == "vm1");
  CHECK(r.host.cpu_model == "AMD EPYC");
  CHECK(r.host.cpus == 2);
  CHECK(r.host.clusters == 1);
  CHECK(r.host.cores_per_cluster == 2);
  CHECK(r.host.freq_mhz == 2445.4);
  CHECK(r.host.line_bytes == 64);
  CHECK(r.host.l1d_kb == 32);
  CHECK(r.host.l2_kb == 512);
  CHECK(r.host.l3_kb_per_cluster == 32768);
  CHECK(r.host.date == "2026-11-23T14:00:00Z");
  REQUIRE(r.runs.size() == 2);
  CHECK(r.runs[0].kernel == "bandwidth_read");
  CHECK(r.runs[0].working_set_kb == 2048);
  CHECK(r.runs[0].corunners.empty());
  CHECK(r.runs[0].ns_per_line == 0.95);
  CHECK(r.runs[0].cv == 0.012);
  CHECK(r.runs[0].samples == 7);
  REQUIRE(r.runs[1].corunners.size() == 1);
  CHECK(r.runs[1].corunners[0].kernel == "bandwidth_write");
  CHECK(r.runs[1].corunners[0].working_set_kb == 131072);
  CHECK(r.runs[1].ns_per_line == 98.5);
  CHECK(r.costs_us == m.costs_us);
  CHECK(r.wall_s == 171.5);
  // And back: the same document.
  json again;
  to_json(again, r);
  CHECK(again == j);
}

TEST_CASE("calibration measurements: a bad document names file and path", "[calibration]") {
  json j;
  to_json(j, sample());
  SECTION("a missing host field") {
    j["host"].erase("l2_kb");
    CHECK_THROWS_WITH(measurements_from_json(j, "c.json", "/measurements"),
                      "c.json: /measurements/host/l2_kb: missing");
  }
  SECTION("a wrong type in a co-runner") {
    j["runs"][1]["corunners"][0]["working_set_kb"] = "big";
    CHECK_THROWS_WITH(measurements_from_json(j, "c.json"),
                      "c.json: /runs/1/corunners/0/working_set_kb: wrong type");
  }
  SECTION("a time per line that is not positive") {
    j["runs"][0]["ns_per_line"] = 0.0;
    CHECK_THROWS_AS(measurements_from_json(j, "c.json"), InputError);
    CHECK_THROWS_WITH(measurements_from_json(j, "c.json"),
                      "c.json: /runs/0/ns_per_line: must be positive");
  }
  SECTION("runs not an array") {
    j["runs"] = json::object();
    CHECK_THROWS_WITH(measurements_from_json(j, "c.json"), "c.json: /runs: not an array");
  }
}

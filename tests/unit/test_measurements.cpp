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
  m.host = {"vm1",        "AMD EPYC", 2, 1, 2, 2445.4, 64, 32, 512, 32768, "2026-11-23T14:00:00Z",
            "Linux 6.1.0"};
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
  CHECK(r.host.kernel == "Linux 6.1.0");
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

TEST_CASE("calibration measurements made before the kernel was recorded still load",
          "[calibration]") {
  json j;
  to_json(j, sample());
  j["host"].erase("kernel");
  const Measurements r = measurements_from_json(j, "c.json");
  CHECK(r.host.kernel.empty());
  CHECK(r.host.cpu_model == "AMD EPYC");
}

TEST_CASE("machine identity: the same machine has no differences, another names each",
          "[calibration]") {
  const MachineIdentity a = machine_identity(sample().host);
  CHECK(a.kernel == "Linux 6.1.0");
  CHECK(identity_differences(a, a).empty());
  MachineIdentity b = a;
  b.hostname = "renamed";  // not compared
  b.date = "2026-11-26T09:00:00Z";
  b.l3_kb_per_cluster = 32768.0 * 1.005;  // within 1 %
  CHECK(identity_differences(a, b).empty());
  b.cpu_model = "Intel(R) Xeon(R) Processor @ 2.50GHz";
  b.l2_kb = 2048;
  b.l3_kb_per_cluster = 36608;
  b.cpus = 16;
  b.kernel = "Linux 6.8.0";
  const auto d = identity_differences(a, b);
  REQUIRE(d.size() == 5);
  CHECK(d[0] ==
        "CPU model 'AMD EPYC' (model) vs 'Intel(R) Xeon(R) Processor @ 2.50GHz' (this "
        "machine)");
  CHECK(d[1] == "usable CPUs 2 (model) vs 16 (this machine)");
  CHECK(d[2] == "L2 512 KB (model) vs 2048 KB (this machine)");
  CHECK(d[3] == "L3 per cluster 32768 KB (model) vs 36608 KB (this machine)");
  CHECK(d[4] == "kernel Linux 6.1.0 (model) vs Linux 6.8.0 (this machine)");
  MachineIdentity old = a;
  old.kernel.clear();
  const auto unknown = identity_differences(old, a);
  REQUIRE(unknown.size() == 1);
  CHECK(unknown[0] == "kernel not recorded by the model (this machine: Linux 6.1.0)");
}

TEST_CASE("machine identity: the platform's measured_on round trip and its errors",
          "[calibration]") {
  const MachineIdentity a = machine_identity(sample().host);
  const json j = identity_to_json(a);
  CHECK(j.at("cpu_model") == "AMD EPYC");
  CHECK(j.at("l3_kb_per_cluster") == 32768.0);
  const MachineIdentity r = identity_from_json(json::parse(j.dump()), "p.json", "/measured_on");
  CHECK(identity_differences(a, r).empty());
  CHECK(r.hostname == "vm1");
  CHECK(r.date == "2026-11-23T14:00:00Z");
  json bad = j;
  bad.erase("cpus");
  CHECK_THROWS_WITH(identity_from_json(bad, "p.json", "/measured_on"),
                    "p.json: /measured_on/cpus: missing");
  CHECK(describe(a) == "AMD EPYC, 2 CPUs, L1d 32 KB, L2 512 KB, L3 32768 KB, Linux 6.1.0");
}

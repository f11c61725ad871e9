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

namespace {

ContentionProbe probe(double ratio, std::optional<double> ci) {
  return {{0, 1}, 131072, ratio, ci, 7, "2026-11-28T07:00:00Z", ""};
}

}  // namespace

TEST_CASE("contention probes: two agree within 10 %, whatever their intervals", "[calibration]") {
  CHECK(same_contention_state(probe(1.70, 2.0), probe(1.80, 2.0)));  // 5.9 %
  CHECK_FALSE(same_contention_state(probe(1.02, 2.0), probe(1.72, 2.0)));
  CHECK_FALSE(same_contention_state(probe(1.35, 1.0), probe(1.51, 1.0)));  // 11.9 % > 10 %
  // Wide intervals do not widen the rule (they would let 1.05x match 1.49x).
  CHECK_FALSE(same_contention_state(probe(1.05, 22.7), probe(1.49, 25.0)));
  CHECK(same_contention_state(probe(1.51, std::nullopt), probe(1.40, 1.0)));  // 7.9 %
  // Symmetric.
  CHECK(same_contention_state(probe(1.0, 1.0), probe(1.105, 1.0)) ==
        same_contention_state(probe(1.105, 1.0), probe(1.0, 1.0)));
}

TEST_CASE("contention probes: a suite's state is its first probe's, the median of those agreeing",
          "[calibration]") {
  CHECK_FALSE(contention_state({}));
  const auto s =
      contention_state({probe(1.80, 3.0), probe(1.02, 2.0), probe(1.70, 6.0), probe(1.84, 4.0)});
  REQUIRE(s);
  CHECK(s->ratio == Approx(1.80));    // 1.70, 1.80, 1.84; 1.02 is another state
  CHECK(s->ci95_pct == Approx(4.0));  // the median of 3, 6 and 4
  CHECK(s->rounds == 21);
  CHECK(s->when == "3 of 4 probes of the suite in this state");
  // Not the first probe's state when most probes are in another (the host moved the vCPUs
  // right after the first).
  const auto moved = contention_state({probe(1.52, 2.0), probe(1.78, 2.0), probe(1.53, 2.0),
                                       probe(0.99, 2.0), probe(1.00, 2.0), probe(0.99, 2.0)});
  REQUIRE(moved);
  CHECK(moved->ratio == Approx(0.99));
  CHECK(moved->when == "3 of 6 probes of the suite in this state");
  CHECK(describe(*s) == "1.80x +- 4.0 % (bandwidth_read 131072 KB on CPU 0 beside CPU 1)");
}

TEST_CASE("contention probes: the host's speed, the reader alone, against the model's",
          "[calibration]") {
  const auto at = [](double ratio, std::optional<double> alone) {
    ContentionProbe p = probe(ratio, 2.0);
    p.alone_ns_per_line = alone;
    return p;
  };
  // The development VM of 2026-11-29: the reader alone 7.3-8.0 ns per line at calibration,
  // 5.8 an hour later, the interference the same.
  const ContentionProbe model = at(1.05, 7.65), later = at(1.04, 5.81);
  CHECK(same_contention_state(model, later));  // the speed is not part of the state
  CHECK(*speed_offset_pct(model, later) == Approx(100.0 * (5.81 / 7.65 - 1.0)));  // -24 %
  CHECK(*speed_offset_pct(later, model) == Approx(100.0 * (7.65 / 5.81 - 1.0)));  // +32 %
  // A probe without its alone time (a model from before rosguard recorded it): not known.
  CHECK_FALSE(speed_offset_pct(at(1.05, std::nullopt), later));
  CHECK_FALSE(speed_offset_pct(later, at(1.05, std::nullopt)));
  // A suite's state: the median alone time of the probes in that state, not of the others.
  const auto s = contention_state(
      {at(1.80, 6.0), at(1.02, 9.0), at(1.70, 5.0), at(1.84, 7.0), at(1.80, std::nullopt)});
  REQUIRE(s);
  CHECK(*s->alone_ns_per_line == Approx(6.0));
  CHECK(describe(*s) ==
        "1.80x +- 2.0 % (bandwidth_read 131072 KB on CPU 0 beside CPU 1; alone 6.00 ns per line)");
  CHECK_FALSE(contention_state({probe(1.0, 1.0)})->alone_ns_per_line);
  // In JSON: written when known, read back, refused when not positive.
  const json j = probe_to_json(later);
  CHECK(j.at("alone_ns_per_line") == 5.81);
  CHECK(*probe_from_json(j, "c.json", "/p").alone_ns_per_line == 5.81);
  CHECK_FALSE(probe_to_json(probe(1.0, 1.0)).contains("alone_ns_per_line"));
  json bad = j;
  bad["alone_ns_per_line"] = 0.0;
  CHECK_THROWS_WITH(probe_from_json(bad, "c.json", "/p"),
                    "c.json: /p/alone_ns_per_line: must be positive");
}

TEST_CASE("contention probes: in the measurements and in measured_on, and their errors",
          "[calibration]") {
  Measurements m = sample();
  m.contention = {probe(1.80, 3.0), probe(1.75, std::nullopt)};
  m.contention[0].when = "before the co-runs";
  m.runs[1].probes = {0, 1};  // the co-run, between the two
  json j;
  to_json(j, m);
  const Measurements r = measurements_from_json(json::parse(j.dump()), "c.json");
  REQUIRE(r.contention.size() == 2);
  CHECK(r.contention[0].ratio == 1.80);
  CHECK(r.contention[0].when == "before the co-runs");
  CHECK_FALSE(r.contention[1].ci95_pct);
  CHECK(r.runs[0].probes.empty());
  CHECK(r.runs[1].probes == std::vector<int>{0, 1});
  CHECK_FALSE(j["runs"][0].contains("probes"));
  json again;
  to_json(again, r);
  CHECK(again == j);
  // Older measurements have no probes.
  json older = j;
  older.erase("contention");
  older["runs"][1].erase("probes");
  CHECK(measurements_from_json(older, "c.json").contention.empty());

  MachineIdentity id = machine_identity(m.host);
  id.dram_contention = contention_state(m.contention);
  const json p = identity_to_json(id);
  const MachineIdentity back = identity_from_json(json::parse(p.dump()), "p.json", "/measured_on");
  REQUIRE(back.dram_contention);
  CHECK(back.dram_contention->ratio == Approx(1.775));
  CHECK(back.dram_contention->ci95_pct == Approx(3.0));  // the one probe with an interval
  CHECK(identity_differences(id, back).empty());
  // A state is not part of the machine's identity.
  MachineIdentity other_state = back;
  other_state.dram_contention = probe(1.02, 2.0);
  CHECK(identity_differences(id, other_state).empty());

  json bad = p;
  bad["dram_contention"]["cores"] = {0};
  CHECK_THROWS_WITH(identity_from_json(bad, "p.json", "/measured_on"),
                    "p.json: /measured_on/dram_contention/cores: must name two CPUs");
  bad = j;
  bad["contention"] = {{{"cores", {0, 1}}, {"ratio", 0.0}}};
  CHECK_THROWS_WITH(measurements_from_json(bad, "c.json"),
                    "c.json: /contention/0/working_set_kb: missing");
  // A run's probes index the probes.
  bad = j;
  bad["runs"][1]["probes"] = {1, 2};
  CHECK_THROWS_WITH(measurements_from_json(bad, "c.json"),
                    "c.json: /runs/1/probes/1: no probe 2 in /contention (2 probes)");
  bad["runs"][1]["probes"] = {0, "1"};
  CHECK_THROWS_WITH(measurements_from_json(bad, "c.json"), Catch::Contains("/runs/1/probes"));
}

TEST_CASE("contention probes: the suite's state is the one most co-runs were measured in",
          "[calibration]") {
  Measurements m = sample();
  m.contention = {probe(1.00, 2.0), probe(1.02, 2.0), probe(1.01, 2.0), probe(1.80, 2.0),
                  probe(1.85, 2.0), probe(1.83, 2.0), probe(1.82, 2.0)};
  // Most probes are at 1.8x (the retakes of a block), most co-runs at 1.0x.
  REQUIRE(contention_state(m.contention)->ratio == Approx(1.825));
  m.runs.clear();
  KernelRun r = sample().runs[1];
  for (int i = 0; i < 16; ++i) {
    r.probes = i < 8 ? std::vector<int>{0, 1} : std::vector<int>{1, 2};
    m.runs.push_back(r);
  }
  r.probes = {2, 3};  // across the change: in neither
  m.runs.push_back(r);
  r.probes = {5, 6};
  for (int i = 0; i < 8; ++i)
    m.runs.push_back(r);
  const auto state = suite_state(m);
  REQUIRE(state);
  CHECK(state->ratio == Approx(1.01));
  CHECK(state->when == "3 of 7 probes of the suite in this state (16 co-runs)");
  // Without the runs' probes (older files): the probes' state.
  for (auto& run : m.runs)
    run.probes.clear();
  CHECK(suite_state(m)->ratio == Approx(1.825));
  m.contention.clear();
  CHECK_FALSE(suite_state(m));
}

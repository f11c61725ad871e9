// `rosguard calibrate --from` through the CLI, on measurements taken on the development VM
// (tests/sim/fixtures/calibration-vm.json): the fit converges, its platform validates and runs
// in sim, --install makes it the host model, bad input is exit 2 and a refused fit exit 1.
#include <catch2/catch.hpp>
#include <cstdlib>
#include <fstream>

#include "sim_test_util.h"

using namespace rosguard;
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

const fs::path kFixture = "tests/sim/fixtures/calibration-vm.json";

json read_json(const fs::path& p) {
  return json::parse(test::read_text(p));
}

// bandwidth_read's measured ns per line alone at `kb`, from the fixture.
double measured_ns(double kb) {
  const json fixture = read_json(test::source_dir() / kFixture);
  for (const auto& r : fixture.at("measurements").at("runs"))
    if (r.at("kernel") == "bandwidth_read" && r.at("working_set_kb") == kb &&
        r.at("corunners").empty())
      return r.at("ns_per_line").get<double>();
  FAIL("no bandwidth_read isolation run at " << kb << " KB in the fixture");
  return 0.0;
}

}  // namespace

TEST_CASE("calibrate --from: the fit converges and its platform runs the shipped workloads in sim",
          "[sim][cli][calibrate]") {
  test::TempDir dir;
  const fs::path out = dir.path() / "cal";
  const auto cal = test::run_cli(
      {"calibrate", "--from", (test::source_dir() / kFixture).string(), "--out", out.string()});
  INFO(cal.output);
  REQUIRE(cal.code == 0);
  CHECK(cal.output.find("fit converged") != std::string::npos);
  const json doc = read_json(out / "calibration.json");
  CHECK(doc.at("status") == "fitted");
  CHECK(doc.at("fit").at("converged") == true);
  CHECK(doc.at("fit").at("rms_residual").get<double>() < 0.15);
  const json platform = read_json(out / "platform.json");
  CHECK(platform.at("kernels").contains("bandwidth_read"));
  CHECK(platform.at("memory").at("dram").at("source").get<std::string>().find("fitted") !=
        std::string::npos);
  CHECK(fs::exists(out / "figures/calibration_isolation.png"));

  // The shipped bandwidth_read (2048 KB x 1314 passes) alone on the fitted platform takes what the
  // measured ns per line says, within the fit's residual there.
  const json scenario = {
      {"name", "on-fitted"},
      {"platform", (out / "platform.json").string()},
      {"nodes",
       {{"controller", {{"core", 0}}},
        {"rt", {{{"name", "rt0"}, {"core", 0}, {"workload", "bandwidth_read"}, {"iterations", 2}}}},
        {"nrt", {{{"name", "nrt0"}, {"core", 1}, {"workload", "bandwidth_write"}}}}}},
      {"regulation", {{"policy", "none"}}}};
  { std::ofstream(dir.path() / "s.json") << scenario.dump(); }
  const auto run = test::run_cli(
      {"run", (dir.path() / "s.json").string(), "--out", (dir.path() / "o").string(), "--quiet"});
  INFO(run.output);
  REQUIRE(run.code == 0);
  const auto rows = test::read_csv(dir.path() / "o/points.csv");
  REQUIRE(rows.size() == 1);
  const double lines = 2048.0 * 1024 / 64 * 1314;
  const double iso_us = std::stod(rows[0].at("rt_isolation_us"));
  CHECK(iso_us == Approx(lines * measured_ns(2048) / 1e3).epsilon(0.10));
}

TEST_CASE("calibrate --install: the fitted platform becomes the host model sim uses",
          "[sim][cli][calibrate]") {
  test::TempDir dir;
  const fs::path model = dir.path() / "share/rosguard/host/platform.json";
  ::setenv("ROSGUARD_HOST_MODEL", model.c_str(), 1);
  const auto cal = test::run_cli({"calibrate", "--from", (test::source_dir() / kFixture).string(),
                                  "--out", (dir.path() / "cal").string(), "--install", "--quiet"});
  INFO(cal.output);
  REQUIRE(cal.code == 0);
  REQUIRE(fs::exists(model));
  CHECK(test::read_text(model) == test::read_text(dir.path() / "cal/platform.json"));
  const auto check = test::run_cli({"check", "scenarios/examples/host.json", "--backend", "sim"});
  INFO(check.output);
  CHECK(check.code == 0);
  ::unsetenv("ROSGUARD_HOST_MODEL");
}

TEST_CASE(
    "calibrate: bad measurements are exit 2 naming the file and path, and --strict refuses "
    "an unidentified bandwidth with exit 1 and keeps the measurements",
    "[sim][cli][calibrate]") {
  test::TempDir dir;
  json broken = read_json(test::source_dir() / kFixture);
  broken["measurements"]["runs"][3].erase("ns_per_line");
  { std::ofstream(dir.path() / "broken.json") << broken.dump(); }
  const auto bad = test::run_cli({"calibrate", "--from", (dir.path() / "broken.json").string(),
                                  "--out", (dir.path() / "b").string()});
  INFO(bad.output);
  CHECK(bad.code == 2);
  CHECK(bad.output.find("broken.json") != std::string::npos);
  CHECK(bad.output.find("/measurements/runs/3/ns_per_line") != std::string::npos);
  CHECK(!fs::exists(dir.path() / "b/platform.json"));

  const auto strict =
      test::run_cli({"calibrate", "--from", (test::source_dir() / kFixture).string(), "--out",
                     (dir.path() / "s").string(), "--strict"});
  INFO(strict.output);
  CHECK(strict.code == 1);
  CHECK(strict.output.find("cannot identify") != std::string::npos);
  CHECK(!fs::exists(dir.path() / "s/platform.json"));
  CHECK(read_json(dir.path() / "s/calibration.json").at("status") == "fit refused");
}

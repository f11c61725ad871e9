// A host model knows its machine (issue 22) through the CLI: `rosguard calibrate` writes
// "measured_on", a sim run with "platform": "host" warns (once, and in the manifest) when the
// model's machine is not this one or is unknown, and `rosguard platform model` says so by its
// exit status (tools/validate.sh recalibrates on 3).
#include <catch2/catch.hpp>
#include <cstdlib>
#include <fstream>

#include "calibration/measurements.h"
#include "load/host_facts.h"
#include "sim_test_util.h"

using namespace rosguard;
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

const std::string kScenario = "scenarios/examples/host.json";
const std::string kOtherMachine = "was measured on another machine";

json read_json(const fs::path& p) {
  return json::parse(test::read_text(p));
}

// vm-2core as the installed model, with `measured_on` (null: none).
fs::path install_model(const fs::path& dir, const json& measured_on) {
  json doc = read_json(test::source_dir() / "scenarios/platforms/vm-2core.json");
  doc.erase("measured_on");
  if (!measured_on.is_null()) doc["measured_on"] = measured_on;
  const fs::path model = dir / "model.json";
  std::ofstream(model) << doc.dump(2);
  ::setenv("ROSGUARD_HOST_MODEL", model.c_str(), 1);
  return model;
}

std::size_t count(const std::string& text, const std::string& part) {
  std::size_t n = 0;
  for (auto at = text.find(part); at != std::string::npos; at = text.find(part, at + 1))
    ++n;
  return n;
}

json run_host(const fs::path& dir, std::string& output) {
  const auto r = test::run_cli(
      {"run", kScenario, "--backend", "sim", "--out", (dir / "o").string(), "--quiet"});
  output = r.output;
  INFO(r.output);
  REQUIRE(r.code == 0);
  return read_json(dir / "o/manifest.json");
}

}  // namespace

TEST_CASE("calibrate writes the machine the measurements come from as measured_on",
          "[sim][cli][calibrate][host]") {
  test::TempDir dir;
  const fs::path fixture = test::source_dir() / "tests/sim/fixtures/calibration-vm.json";
  const auto cal = test::run_cli(
      {"calibrate", "--from", fixture.string(), "--out", (dir.path() / "cal").string(), "--quiet"});
  INFO(cal.output);
  REQUIRE(cal.code == 0);
  const json on = read_json(dir.path() / "cal/platform.json").at("measured_on");
  const json host = read_json(fixture).at("measurements").at("host");
  CHECK(on.at("cpu_model") == host.at("cpu_model"));
  CHECK(on.at("cpus") == host.at("cpus"));
  CHECK(on.at("l1d_kb") == host.at("l1d_kb"));
  CHECK(on.at("l2_kb") == host.at("l2_kb"));
  CHECK(on.at("l3_kb_per_cluster") == host.at("l3_kb_per_cluster"));
  CHECK(on.at("hostname") == host.at("hostname"));
  CHECK(on.at("date") == host.at("date"));
  // The fixture predates the kernel's recording: none invented, and the output says so.
  CHECK_FALSE(on.contains("kernel"));
  CHECK(cal.output.find("measured on AMD EPYC, 2 CPUs") != std::string::npos);
  CHECK(cal.output.find("do not record their kernel") != std::string::npos);
}

TEST_CASE("platform host in sim: a model of this machine runs without a machine warning",
          "[sim][cli][host]") {
  test::TempDir dir;
  install_model(dir.path(), calibration::identity_to_json(this_machine()));
  std::string output;
  const json manifest = run_host(dir.path(), output);
  CHECK(output.find(kOtherMachine) == std::string::npos);
  CHECK(output.find("is unknown") == std::string::npos);
  for (const auto& w : manifest.at("warnings"))
    CHECK(w.get<std::string>().find("host model") == std::string::npos);
  const json machine = manifest.at("host_platform").at("sim").at("machine");
  CHECK(machine.at("matches") == true);
  CHECK(machine.at("differences").empty());
  const auto status = test::run_cli({"platform", "model"});
  INFO(status.output);
  CHECK(status.code == 0);
  CHECK(status.output.find("the host model was measured on this machine") != std::string::npos);
  ::unsetenv("ROSGUARD_HOST_MODEL");
}

TEST_CASE(
    "platform host in sim: a model of another machine warns once, naming what differs, and the "
    "manifest records it",
    "[sim][cli][host]") {
  test::TempDir dir;
  calibration::MachineIdentity other = this_machine();
  other.cpu_model = "Some Other CPU";
  other.cpus += 1;
  other.hostname = "elsewhere";
  install_model(dir.path(), calibration::identity_to_json(other));
  std::string output;
  const json manifest = run_host(dir.path(), output);
  INFO(output);
  CHECK(count(output, kOtherMachine) == 1);
  CHECK(output.find("warning: platform \"host\" in sim runs the installed host model") !=
        std::string::npos);
  CHECK(output.find("CPU model 'Some Other CPU' (model) vs") != std::string::npos);
  CHECK(output.find("usable CPUs " + std::to_string(other.cpus) + " (model) vs") !=
        std::string::npos);
  int recorded = 0;
  for (const auto& w : manifest.at("warnings"))
    recorded += w.get<std::string>().find(kOtherMachine) != std::string::npos ? 1 : 0;
  CHECK(recorded == 1);
  const json machine = manifest.at("host_platform").at("sim").at("machine");
  CHECK(machine.at("matches") == false);
  CHECK(machine.at("differences").size() == 2);
  CHECK(machine.at("measured_on").at("hostname") == "elsewhere");

  // check says it once too; platform model exits 3.
  const auto check = test::run_cli({"check", kScenario, "--backend", "sim"});
  CHECK(check.code == 0);
  CHECK(count(check.output, kOtherMachine) == 1);
  const auto status = test::run_cli({"platform", "model"});
  INFO(status.output);
  CHECK(status.code == 3);
  CHECK(status.output.find("CPU model 'Some Other CPU'") != std::string::npos);
  ::unsetenv("ROSGUARD_HOST_MODEL");
}

TEST_CASE("platform host in sim: a model without measured_on warns that its machine is unknown",
          "[sim][cli][host]") {
  test::TempDir dir;
  install_model(dir.path(), nullptr);
  std::string output;
  const json manifest = run_host(dir.path(), output);
  INFO(output);
  CHECK(count(output, "does not record the machine it was measured on") == 1);
  bool recorded = false;
  for (const auto& w : manifest.at("warnings"))
    recorded = recorded || w.get<std::string>().find("is unknown") != std::string::npos;
  CHECK(recorded);
  CHECK(manifest.at("host_platform").at("sim").at("machine").at("matches").is_null());
  CHECK(test::run_cli({"platform", "model"}).code == 3);

  ::setenv("ROSGUARD_HOST_MODEL", (dir.path() / "none.json").c_str(), 1);
  const auto none = test::run_cli({"platform", "model"});
  CHECK(none.code == 3);
  CHECK(none.output.find("no host model installed") != std::string::npos);
  ::unsetenv("ROSGUARD_HOST_MODEL");
}

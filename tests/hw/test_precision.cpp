// Adaptive repetitions through the real binary (hw.precision_pct 50 %, hw.max_repetitions 3:
// docs/design.md section 5): every point runs within its rounds (at least the minimum, at most
// the cap), baselines once per round, the slowdown CI columns filled in every row, the reached
// precision and rounds per point in the manifest, the summary line naming both; and the hw
// run's own threads placed and the measured CPUs timed (manifest). No timing assertion.
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "hw_test_files.h"
#include "results/precision.h"
#include "results/results.h"

namespace fs = std::filesystem;
using rosguard::test::lines_of;
using rosguard::test::slurp;

TEST_CASE("hw run with precision 50 % and cap 3: rounds within the cap, CI columns filled",
          "[hw][precision]") {
  const fs::path out =
      fs::temp_directory_path() / ("rosguard-precision-" + std::to_string(::getpid()));
  fs::remove_all(out);
  const fs::path err = out.string() + ".stderr", so = out.string() + ".stdout";
  const std::string scenario =
      std::string(ROSGUARD_TEST_SOURCE_DIR) + "/tests/hw/scenarios/precision.json";
  const std::string command = std::string(ROSGUARD_BINARY) + " run " + scenario +
                              " --backend hw --out " + out.string() + " > " + so.string() + " 2> " +
                              err.string();
  const int status = std::system(command.c_str());
  INFO(slurp(err));
  REQUIRE(WIFEXITED(status));
  REQUIRE(WEXITSTATUS(status) == 0);

  const auto rule = rosguard::precision_rule(1, 50.0, 3);
  const auto points = lines_of(slurp(out / "points.csv"));
  REQUIRE(points.size() > 1);
  const auto header = rosguard::csv_split(points[0]);
  const auto col = [&](const std::string& name) {
    const auto it = std::find(header.begin(), header.end(), name);
    REQUIRE(it != header.end());
    return static_cast<std::size_t>(it - header.begin());
  };
  std::map<std::string, int> rounds;
  std::map<std::string, std::string> rt_ci;
  for (std::size_t i = 1; i < points.size(); ++i) {
    const auto cells = rosguard::csv_split(points[i]);
    INFO(points[i]);
    ++rounds[cells[col("point")]];
    // Every row carries its point's CIs (one value per point).
    for (const char* c : {"rt_slowdown_ci95_pct", "nrt_slowdown_ci95_pct"}) {
      REQUIRE_FALSE(cells[col(c)].empty());
      CHECK(std::stod(cells[col(c)]) >= 0.0);
    }
    const auto [it, fresh] = rt_ci.emplace(cells[col("point")], cells[col("rt_slowdown_ci95_pct")]);
    CHECK(it->second == cells[col("rt_slowdown_ci95_pct")]);
  }
  REQUIRE(rounds.size() == 2);
  int most = 0;
  for (const auto& [point, n] : rounds) {
    INFO(point);
    CHECK(n >= rule.min_rounds);
    CHECK(n <= 3);
    most = std::max(most, n);
  }
  // One baseline measurement per round (as many as the most rounds a point using it ran).
  const auto baselines = nlohmann::json::parse(slurp(out / "baselines.json"));
  for (const auto& [key, b] : baselines.items())
    CHECK(b.at("runs").size() == static_cast<std::size_t>(most));

  const auto m = nlohmann::json::parse(slurp(out / "manifest.json"));
  CHECK(m.at("status") == "complete");
  const auto& p = m.at("precision");
  CHECK(p.at("target_pct") == 50.0);
  CHECK(p.at("max_repetitions") == 3);
  REQUIRE(p.at("points").size() == 2);
  for (const auto& [id, e] : p.at("points").items()) {
    INFO(id);
    CHECK(e.at("repetitions") == rounds.at(id));
    const std::string verdict = e.at("verdict");
    CHECK((verdict == "precise" || verdict == "capped"));
    CHECK(e.contains("rt_slowdown_ci95_pct"));
    CHECK(e.contains("nrt_slowdown_ci95_pct"));
  }
  CHECK_THAT(slurp(so), Catch::Contains("slowdown 95 % CI within 50 % on"));
  // Where rosguard's own threads ran, what the host offers, the measured CPUs' speed.
  const auto& facts = m.at("facts");
  CHECK(facts.contains("housekeeping"));
  CHECK(facts.contains("host_isolation"));
  CHECK(facts.contains("thread_placement_inproc"));
  const auto& speed = m.at("cpu_speed");
  CHECK(speed.at("cpus").size() == 2);  // CPUs 0 (RT) and 1 (nRT)
  for (const auto& [cpu, figures] : speed.at("cpus").items())
    CHECK(figures.at("windows_mbps").size() == 5);
  CHECK_THAT(slurp(err), Catch::Contains("hw: rosguard's own threads on CPU"));
  fs::remove_all(out);
  fs::remove(err);
  fs::remove(so);
}

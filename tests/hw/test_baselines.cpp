// Repeated isolation baselines through the real binary (docs/design.md, sections 5 and 6): a hw
// run with repetitions 3 measures every baseline 3 times, keeps every measurement in
// baselines.json and the manifest, writes the median, its count and spread into every row and
// computes the slowdowns against the median; every RT job has its rt_job sample.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "backend/backend.h"
#include "hw_test_files.h"
#include "results/results.h"
#include "store/results_store.h"

namespace fs = std::filesystem;
using rosguard::test::lines_of;
using rosguard::test::slurp;

namespace {

// The cells of a points.csv row by column name.
std::map<std::string, std::string> row_cells(const std::vector<std::string>& header,
                                             const std::string& line) {
  const auto cells = rosguard::csv_split(line);
  REQUIRE(cells.size() == header.size());
  std::map<std::string, std::string> out;
  for (std::size_t i = 0; i < header.size(); ++i)
    out[header[i]] = cells[i];
  return out;
}

}  // namespace

TEST_CASE("hw run with repetitions 3: 3 baselines each, their median and spread in every row",
          "[hw][baselines]") {
  const fs::path out =
      fs::temp_directory_path() / ("rosguard-baselines-" + std::to_string(::getpid()));
  fs::remove_all(out);
  const fs::path err = out.string() + ".stderr";
  const std::string scenario =
      std::string(ROSGUARD_TEST_SOURCE_DIR) + "/tests/hw/scenarios/baselines.json";
  const std::string command = std::string(ROSGUARD_BINARY) + " run " + scenario +
                              " --backend hw --quiet --out " + out.string() + " 2> " + err.string();
  const int status = std::system(command.c_str());
  INFO(slurp(err));
  REQUIRE(WIFEXITED(status));
  REQUIRE(WEXITSTATUS(status) == 0);

  // Two baselines (the RT and the nRT workload), 3 measurements each, all kept.
  const auto doc = nlohmann::json::parse(slurp(out / "baselines.json"));
  REQUIRE(doc.size() == 2);
  const rosguard::Baselines baselines = rosguard::baselines_from_json(doc);
  for (const auto& [key, runs] : baselines.all()) {
    INFO(key);
    CHECK(runs.count() == 3);
    CHECK(doc.at(key).at("runs").size() == 3);
    CHECK(doc.at(key).at("time_us").get<double>() == runs.median().time_us);
  }
  const auto manifest = nlohmann::json::parse(slurp(out / "manifest.json"));
  CHECK(manifest.at("status") == "complete");
  for (const auto& [key, runs] : baselines.all()) {
    const auto& m = manifest.at("baselines").at(key);
    CHECK(m.at("measurements") == 3);
    CHECK(m.at("time_us_each").size() == 3);
    // The warning decision: a baseline above 5 % is in the manifest's warnings (and stderr).
    const std::string warning = runs.noise_warning(key);
    const auto& warnings = manifest.at("warnings");
    CHECK((std::find(warnings.begin(), warnings.end(), warning) != warnings.end()) ==
          runs.too_noisy());
    if (runs.too_noisy()) CHECK_THAT(slurp(err), Catch::Contains(warning));
  }

  // Every row: the median of the 3 measurements, n = 3, the spread, and slowdown = time / median.
  const auto key_of = [&](const std::string& workload) {
    for (const auto& [key, runs] : baselines.all())
      if (key.rfind(workload + "/", 0) == 0) return key;
    FAIL("no baseline of " << workload);
    return std::string();
  };
  const auto& rt_runs = baselines.all().at(key_of("bandwidth_read_4m"));
  const auto& nrt_runs = baselines.all().at(key_of("bandwidth_read_16m"));
  const auto points = lines_of(slurp(out / "points.csv"));
  REQUIRE(points.size() == 1 + 2 * 3);
  const auto header = rosguard::csv_split(points[0]);
  std::map<std::pair<std::string, std::string>, int> jobs;  // (point, rep) -> rt_jobs
  for (std::size_t i = 1; i < points.size(); ++i) {
    auto c = row_cells(header, points[i]);
    INFO(points[i]);
    CHECK(c["rt_isolation_n"] == "3");
    CHECK(c["nrt_isolation_n"] == "3");
    CHECK(std::stod(c["rt_isolation_us"]) == Approx(rt_runs.median().time_us).margin(1e-3));
    CHECK(std::stod(c["nrt_isolation_us"]) == Approx(nrt_runs.median().time_us).margin(1e-3));
    CHECK(std::stod(c["rt_isolation_cv"]) == Approx(rt_runs.time_cv()).margin(1e-6));
    CHECK(std::stod(c["nrt_isolation_cv"]) == Approx(nrt_runs.time_cv()).margin(1e-6));
    CHECK(std::stod(c["rt_slowdown"]) ==
          Approx(std::stod(c["rt_time_us"]) / rt_runs.median().time_us).epsilon(1e-5));
    CHECK(std::stod(c["nrt_slowdown"]) ==
          Approx(std::stod(c["nrt_time_us"]) / nrt_runs.median().time_us).epsilon(1e-5));
    CHECK(c["rt_jobs"] == "4");
    const int misses = std::stoi(c["rt_deadline_misses"]);
    CHECK(misses >= 0);
    CHECK(misses <= 4);
    CHECK(std::stod(c["rt_response_max_us"]) >= std::stod(c["rt_response_p99_us"]));
    jobs[{c["point"], c["rep"]}] = std::stoi(c["rt_jobs"]);
  }

  // One rt_job sample per job, release to finish: never shorter than the job itself.
  std::map<std::pair<std::string, std::string>, int> samples;
  for (const auto& line : lines_of(slurp(out / "samples.csv"))) {
    const auto cells = rosguard::csv_split(line);
    if (cells.at(2) != "rt_job") continue;
    ++samples[{cells.at(0), cells.at(1)}];
    CHECK(std::stod(cells.at(3)) > 0.0);
  }
  CHECK(samples == jobs);
  fs::remove_all(out);
  fs::remove(err);
}

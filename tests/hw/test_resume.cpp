// Resume through the real binary: a hw run interrupted with SIGINT and continued with --resume
// ends with every (point, rep) exactly once and the manifest complete. On a machine without a
// hardware PMU the counter source has no IPC, so baselines.json holds "ipc": null, which the
// resumed run must read back as "not measured". Each baseline is measured 6 times (as many as
// the repetitions), interleaved with the rounds; the resumed run measures the ones the
// interrupted one did not, and every row ends with the median of all 6.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>
#include <vector>

#include "hw_test_files.h"
#include "results/results.h"

namespace fs = std::filesystem;

using rosguard::test::lines_of;
using rosguard::test::slurp;

namespace {

// Starts `rosguard run SCENARIO --backend hw --out OUT [extra]` with stderr into `err`.
pid_t start_run(const std::string& scenario, const fs::path& out, const fs::path& err,
                const char* extra) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int fd = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(fd, 2);
    ::execl(ROSGUARD_BINARY, ROSGUARD_BINARY, "run", scenario.c_str(), "--backend", "hw", "--out",
            out.c_str(), extra, static_cast<char*>(nullptr));
    ::_exit(127);
  }
  return pid;
}

int exit_code(pid_t pid) {
  int status = 0;
  if (::waitpid(pid, &status, 0) != pid) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

}  // namespace

TEST_CASE("SIGINT then --resume: every (point, rep) exactly once, manifest complete",
          "[hw][resume]") {
  const fs::path out =
      fs::temp_directory_path() / ("rosguard-resume-" + std::to_string(::getpid()));
  fs::remove_all(out);
  const fs::path err = out.string() + ".stderr";
  const std::string scenario =
      std::string(ROSGUARD_TEST_SOURCE_DIR) + "/tests/hw/scenarios/resume.json";
  const std::size_t expected_rows = 2 * 6;  // points x repetitions

  const pid_t pid = start_run(scenario, out, err, "--quiet");
  REQUIRE(pid > 0);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (std::chrono::steady_clock::now() < deadline &&
         lines_of(slurp(out / "points.csv")).size() < 3)  // header + 2 rows
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  std::this_thread::sleep_for(std::chrono::milliseconds(40));  // land inside a point
  REQUIRE(::kill(pid, SIGINT) == 0);
  {
    const int code = exit_code(pid);
    INFO(slurp(err));
    REQUIRE(code == 130);
  }
  const std::size_t rows_before = lines_of(slurp(out / "points.csv")).size() - 1;
  REQUIRE(rows_before >= 2);
  REQUIRE(rows_before < expected_rows);
  CHECK_THAT(slurp(out / "manifest.json"), Catch::Contains("\"interrupted\""));
  const std::string baselines = slurp(out / "baselines.json");
  INFO("baselines.json: " << baselines);

  const int code = exit_code(start_run(scenario, out, err, "--resume"));
  const std::string stderr_text = slurp(err);
  INFO(stderr_text);
  REQUIRE(code == 0);
  CHECK_THAT(stderr_text, !Catch::Contains("internal"));
  CHECK_THAT(stderr_text,
             Catch::Contains("resume: " + std::to_string(rows_before) + " run(s) already in"));

  const auto points = lines_of(slurp(out / "points.csv"));
  REQUIRE(points.size() == expected_rows + 1);
  std::map<std::pair<std::string, std::string>, int> seen;
  const auto header = rosguard::csv_split(points[0]);
  const auto column = [&](const char* name) {
    return static_cast<std::size_t>(std::find(header.begin(), header.end(), name) - header.begin());
  };
  for (std::size_t i = 1; i < points.size(); ++i) {
    const auto cells = rosguard::csv_split(points[i]);
    ++seen[{cells.at(0), cells.at(1)}];
    INFO(points[i]);
    CHECK(cells.at(column("rt_isolation_n")) == "6");
    CHECK(cells.at(column("nrt_isolation_n")) == "6");
  }
  const auto baselines_after = nlohmann::json::parse(slurp(out / "baselines.json"));
  for (const auto& [key, entry] : baselines_after.items()) {
    INFO(key);
    CHECK(entry.at("runs").size() == 6);
  }
  CHECK(seen.size() == expected_rows);
  for (const auto& [key, count] : seen) {
    INFO("point " << key.first << " rep " << key.second);
    CHECK(count == 1);
  }
  for (const auto& line : lines_of(slurp(out / "samples.csv"))) {
    const auto cells = rosguard::csv_split(line);
    if (cells.at(0) != "point") CHECK(seen.count({cells.at(0), cells.at(1)}) == 1);
  }
  const auto manifest = nlohmann::json::parse(slurp(out / "manifest.json"));
  CHECK(manifest.at("status") == "complete");
  CHECK(manifest.at("counts").at("rows") == expected_rows);
  fs::remove_all(out);
  fs::remove(err);
}

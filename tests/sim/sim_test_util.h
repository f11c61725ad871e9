// Helpers of the sim tests.
//
// SystemC elaborates once per process, so every simulation a test runs goes through in_child():
// a forked child runs it and sends back a JSON value. ctest already runs each TEST_CASE in its
// own process; in_child() also lets one case run many simulations, and lets the test binary run
// all cases in one process.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "backend/backend.h"
#include "scenario/scenario.h"
#include "system.h"

namespace rosguard::test {

// Runs `fn` in a forked child and returns what it returned; a child that throws or dies fails
// the calling test with its message.
nlohmann::json in_child(const std::function<nlohmann::json()>& fn);

// The source tree (scenarios/, tests/).
std::filesystem::path source_dir();
// A fresh temporary folder, removed by the destructor.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// Loads a scenario file (path relative to the source tree, or absolute) and returns its points.
std::vector<Scenario> load_points(const std::string& file);
// A scenario from an inline JSON document (written to `dir`), for one-off setups.
std::vector<Scenario> load_points_json(const nlohmann::json& doc, const std::filesystem::path& dir);

// Simulations (each in its own child process).
IsolationResult isolation(const Scenario& s, const WorkloadInfo& w, int core);
// Isolation baselines for every node of `s`, then the point; the full report, as JSON.
nlohmann::json run_point_report(const Scenario& s, std::uint64_t seed = 1);

// The rosguard executable: exit code and combined output.
struct CliResult {
  int code = -1;
  std::string output;
};
CliResult run_cli(const std::vector<std::string>& args);

// A CSV file as rows of column -> cell.
std::vector<std::map<std::string, std::string>> read_csv(const std::filesystem::path& file);
std::string read_text(const std::filesystem::path& file);
double num(const std::map<std::string, std::string>& row, const std::string& column);

}  // namespace rosguard::test

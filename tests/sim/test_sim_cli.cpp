// The sim backend through the CLI: determinism whatever --jobs and sharding, trace.json, and a
// run killed mid-sweep that --resume completes.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <chrono>
#include <fstream>
#include <set>
#include <thread>

#include "results/results.h"
#include "sim_test_util.h"

using namespace rosguard;
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (start < text.size()) {
    const std::size_t end = text.find('\n', start);
    if (end == std::string::npos) {
      out.push_back(text.substr(start));  // a torn last line
      break;
    }
    out.push_back(text.substr(start, end - start));
    start = end + 1;
  }
  return out;
}

// A sweep long enough to be killed in the middle: 60 points of 5 RT jobs each.
json long_sweep() {
  std::vector<double> thresholds;
  for (int i = 1; i <= 30; ++i)
    thresholds.push_back(i);
  return {
      {"name", "long"},
      {"repetitions", 1},
      {"nodes",
       {{"controller", {{"core", 0}}},
        {"rt", {{{"name", "rt0"}, {"core", 1}, {"workload", "mser"}, {"iterations", 5}}}},
        {"nrt", {{{"name", "nrt0"}, {"core", 2}, {"workload", "bandwidth_read"}}}}}},
      {"regulation", {{"sampling_period_us", 100}, {"regulation_period_us", 1000}}},
      {"sweep",
       {{"regulation.threshold_pct", thresholds}, {"regulation.sampling", {"self", "external"}}}}};
}

}  // namespace

TEST_CASE(
    "determinism: the same scenario and seed give byte-identical points.csv and "
    "samples.csv with --jobs 1, --jobs 2, and two shards into one folder",
    "[sim][cli][determinism]") {
  test::TempDir dir;
  const std::string s = "scenarios/quickstart.json";
  const auto a = dir.path() / "jobs1", b = dir.path() / "jobs2", c = dir.path() / "shards";
  REQUIRE(test::run_cli({"run", s, "--out", a.string(), "--jobs", "1", "--quiet"}).code == 0);
  REQUIRE(test::run_cli({"run", s, "--out", b.string(), "--jobs", "2", "--quiet"}).code == 0);
  REQUIRE(test::run_cli({"run", s, "--out", c.string(), "--shard", "1/2", "--jobs", "2", "--quiet"})
              .code == 0);
  REQUIRE(test::run_cli({"run", s, "--out", c.string(), "--shard", "0/2", "--jobs", "1", "--quiet"})
              .code == 0);
  const std::string points = test::read_text(a / "points.csv");
  CHECK(lines_of(points).size() == 1 + 12 * 3);
  CHECK(test::read_text(b / "points.csv") == points);
  CHECK(test::read_text(c / "points.csv") == points);
  const std::string samples = test::read_text(a / "samples.csv");
  CHECK(test::read_text(b / "samples.csv") == samples);
  CHECK(test::read_text(c / "samples.csv") == samples);
  // A different seed gives different draws (and so different bytes).
  test::TempDir other;
  json doc = json::parse(test::read_text(test::source_dir() / s));
  doc["seed"] = 2;
  const auto f = other.path() / "seed2.json";
  std::ofstream(f) << doc.dump(2);
  REQUIRE(
      test::run_cli({"run", f.string(), "--out", (other.path() / "o").string(), "--quiet"}).code ==
      0);
  CHECK(test::read_text(other.path() / "o" / "samples.csv") != samples);
}

TEST_CASE(
    "trace: --trace writes a Chrome trace with node states, throttles, RT jobs and "
    "bandwidth counters",
    "[sim][cli][trace]") {
  test::TempDir dir;
  const auto out = dir.path() / "t";
  const auto r = test::run_cli(
      {"run", "scenarios/quickstart.json", "--out", out.string(), "--trace", "--quiet"});
  INFO(r.output);
  REQUIRE(r.code == 0);
  const json trace = json::parse(test::read_text(out / "trace.json"));
  REQUIRE(trace.contains("traceEvents"));
  const auto& events = trace["traceEvents"];
  std::map<std::string, int> names;  // thread names
  int spans = 0, counters = 0, states = 0, throttles = 0, jobs = 0;
  std::set<std::string> state_names;
  for (const auto& e : events) {
    REQUIRE(e.contains("ph"));
    REQUIRE(e.contains("pid"));
    const std::string ph = e["ph"];
    if (ph == "M") {
      if (e["name"] == "thread_name") names[e["args"]["name"]]++;
      continue;
    }
    REQUIRE(e.contains("ts"));
    CHECK(e["ts"].get<double>() >= 0.0);
    if (ph == "X") {
      ++spans;
      CHECK(e["dur"].get<double>() >= 0.0);
      const std::string n = e["name"];
      if (n == "OFF" || n == "ON" || n == "THR") {
        ++states;
        state_names.insert(n);
      }
      jobs += n.rfind("job ", 0) == 0;
    } else if (ph == "C") {
      ++counters;
      CHECK(e["args"].is_object());
    }
  }
  for (const auto& [n, count] : names)
    throttles += n.find("throttle") != std::string::npos;
  CHECK(spans > 0);
  CHECK(counters > 0);
  CHECK(states > 0);
  CHECK(state_names.count("THR"));
  CHECK(state_names.count("ON"));
  CHECK(throttles > 0);
  CHECK(jobs == 12 * 3);  // one RT job per point and repetition
  CHECK(names.count("core 2: nrt0 state"));
  CHECK(names.count("core 1: rt0 jobs"));
}

TEST_CASE(
    "a run killed with SIGKILL mid-sweep leaves only complete rows, and --resume "
    "completes it to the same bytes as an uninterrupted run",
    "[sim][cli][resume]") {
  test::TempDir dir;
  const auto scenario = dir.path() / "long.json";
  std::ofstream(scenario) << long_sweep().dump(2);
  const auto clean = dir.path() / "clean", killed = dir.path() / "killed";
  REQUIRE(test::run_cli({"run", scenario.string(), "--out", clean.string(), "--quiet"}).code == 0);
  const std::string expected = test::read_text(clean / "points.csv");
  const auto expected_lines = lines_of(expected);
  REQUIRE(expected_lines.size() == 61);

  // Start a run, let it write some rows, kill it.
  bool interrupted = false;
  for (int attempt = 0; attempt < 5 && !interrupted; ++attempt) {
    fs::remove_all(killed);
    const pid_t pid = ::fork();
    REQUIRE(pid >= 0);
    if (pid == 0) {
      ::setenv("ROSGUARD_HOME", test::source_dir().c_str(), 1);
      ::execl(ROSGUARD_TEST_BIN, ROSGUARD_TEST_BIN, "run", scenario.c_str(), "--out",
              killed.c_str(), "--quiet", "--jobs", "1", static_cast<char*>(nullptr));
      ::_exit(127);
    }
    // Wait for a few rows, then kill.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    std::size_t rows = 0;
    while (std::chrono::steady_clock::now() < deadline) {
      rows = lines_of(test::read_text(killed / "points.csv")).size();
      if (rows >= 6) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    ::kill(pid, SIGKILL);
    int status = 0;
    ::waitpid(pid, &status, 0);
    const auto lines = lines_of(test::read_text(killed / "points.csv"));
    interrupted = WIFSIGNALED(status) && lines.size() < expected_lines.size();
    if (!interrupted) continue;
    // Only complete rows: the header, then rows with every column, each one of the clean run's.
    REQUIRE(!lines.empty());
    CHECK(lines.front() == expected_lines.front());
    const std::string text = test::read_text(killed / "points.csv");
    CHECK(text.back() == '\n');
    const std::size_t columns = csv_split(lines.front()).size();
    for (std::size_t i = 1; i < lines.size(); ++i) {
      CHECK(csv_split(lines[i]).size() == columns);
      CHECK(std::find(expected_lines.begin(), expected_lines.end(), lines[i]) !=
            expected_lines.end());
    }
  }
  REQUIRE(interrupted);
  // Orphaned workers die on their broken pipe; resume the run.
  const auto r = test::run_cli(
      {"run", scenario.string(), "--out", killed.string(), "--resume", "--quiet", "--jobs", "2"});
  INFO(r.output);
  REQUIRE(r.code == 0);
  CHECK(test::read_text(killed / "points.csv") == expected);
  CHECK(test::read_text(killed / "samples.csv") == test::read_text(clean / "samples.csv"));
}

TEST_CASE("every shipped scenario is valid for the sim backend, and the examples run",
          "[sim][cli][scenarios]") {
  int checked = 0;
  // "platform": "host" scenarios run here on sim, with the VM's model as the installed one.
  ::setenv("ROSGUARD_HOST_MODEL",
           (test::source_dir() / "scenarios/platforms/vm-2core.json").c_str(), 1);
  for (const auto& e : fs::recursive_directory_iterator(test::source_dir() / "scenarios")) {
    const auto rel = fs::relative(e.path(), test::source_dir()).string();
    if (e.path().extension() != ".json" || rel.find("/schema/") != std::string::npos ||
        rel.find("/platforms/") != std::string::npos ||
        rel.find("/workloads/") != std::string::npos ||
        rel.find("/profiles/") != std::string::npos ||  // workload documents (rosguard profile)
        // up to 15 cores: checked on a 16-core model (tests/app/validate_scale.sh)
        rel.find("/validation/scale/") != std::string::npos)
      continue;
    const bool host =
        nlohmann::json::parse(test::read_text(e.path())).value("platform", "") == "host";
    std::vector<std::string> on_sim;
    if (host) on_sim = {"--backend", "sim"};
    auto check = std::vector<std::string>{"check", rel};
    check.insert(check.end(), on_sim.begin(), on_sim.end());
    const auto r = test::run_cli(check);
    INFO(rel << ": " << r.output);
    CHECK(r.code == 0);
    ++checked;
    if (rel.find("/examples/") != std::string::npos) {
      test::TempDir dir;
      auto run =
          std::vector<std::string>{"run", rel, "--out", (dir.path() / "o").string(), "--quiet"};
      run.insert(run.end(), on_sim.begin(), on_sim.end());
      CHECK(test::run_cli(run).code == 0);
    }
  }
  CHECK(checked >= 12);
}

TEST_CASE("platform host on sim: the installed model from ROSGUARD_HOST_MODEL, or exit 2 without",
          "[sim][cli][host]") {
  test::TempDir dir;
  const std::string scenario = "scenarios/examples/host.json";
  ::setenv("ROSGUARD_HOST_MODEL", (dir.path() / "missing.json").c_str(), 1);
  const auto missing = test::run_cli({"check", scenario, "--backend", "sim"});
  INFO(missing.output);
  CHECK(missing.code == 2);
  CHECK(missing.output.find("/platform") != std::string::npos);
  CHECK(missing.output.find("no calibrated model of this host: run `rosguard calibrate "
                            "--install` (or use --backend hw)") != std::string::npos);
  CHECK(!fs::exists(dir.path() / "o"));

  const fs::path model = dir.path() / "model.json";
  fs::copy_file(test::source_dir() / "scenarios/platforms/vm-2core.json", model);
  ::setenv("ROSGUARD_HOST_MODEL", model.c_str(), 1);
  const auto run = test::run_cli(
      {"run", scenario, "--backend", "sim", "--out", (dir.path() / "o").string(), "--quiet"});
  INFO(run.output);
  REQUIRE(run.code == 0);
  const auto manifest = nlohmann::json::parse(test::read_text(dir.path() / "o/manifest.json"));
  CHECK(manifest.at("backend") == "sim");
  CHECK(manifest.at("host_platform").at("sim").at("model") == model.string());
  CHECK(manifest.at("platform").at("doc").at("name") == "vm-2core");
  CHECK(test::read_csv(dir.path() / "o/points.csv").size() == 2);

  // An installed model that is not a valid platform is the model file's error.
  { std::ofstream(model) << R"({"name": "host"})"; }
  const auto invalid = test::run_cli({"check", scenario, "--backend", "sim"});
  CHECK(invalid.code == 2);
  CHECK(invalid.output.find("model.json") != std::string::npos);
}

#include "sim_test_util.h"

#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cerrno>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>

#include "backend.h"
#include "load/loader.h"
#include "policy/builtin_registry.h"
#include "results/results.h"

#ifndef ROSGUARD_TEST_SOURCE_DIR
#error "ROSGUARD_TEST_SOURCE_DIR must point at the source tree"
#endif
#ifndef ROSGUARD_TEST_BIN
#error "ROSGUARD_TEST_BIN must point at the rosguard executable"
#endif

namespace rosguard::test {
namespace fs = std::filesystem;
using json = nlohmann::json;

json in_child(const std::function<json()>& fn) {
  int fds[2];
  REQUIRE(::pipe(fds) == 0);
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    ::close(fds[0]);
    std::string payload;
    try {
      payload = json{{"ok", true}, {"value", fn()}}.dump();
    } catch (const std::exception& e) {
      payload = json{{"ok", false}, {"error", e.what()}}.dump();
    }
    const char* p = payload.data();
    std::size_t left = payload.size();
    while (left > 0) {
      const ssize_t n = ::write(fds[1], p, left);
      if (n <= 0) ::_exit(3);
      p += n;
      left -= static_cast<std::size_t>(n);
    }
    ::_exit(0);
  }
  ::close(fds[1]);
  std::string data;
  char buf[65536];
  while (true) {
    const ssize_t n = ::read(fds[0], buf, sizeof buf);
    if (n > 0) {
      data.append(buf, static_cast<std::size_t>(n));
    } else if (n < 0 && errno == EINTR) {
      continue;
    } else {
      break;
    }
  }
  ::close(fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  INFO("child exit status " << status);
  REQUIRE(!data.empty());
  const json j = json::parse(data);
  INFO("child error: " << j.value("error", ""));
  REQUIRE(j.at("ok").get<bool>());
  return j.at("value");
}

fs::path source_dir() {
  return fs::path(ROSGUARD_TEST_SOURCE_DIR);
}

TempDir::TempDir() {
  std::random_device rd;
  path_ = fs::temp_directory_path() /
          ("rosguard-sim-test-" + std::to_string(::getpid()) + "-" + std::to_string(rd()));
  fs::create_directories(path_);
}

TempDir::~TempDir() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

std::vector<Scenario> load_points(const std::string& file) {
  const fs::path p = fs::path(file).is_absolute() ? fs::path(file) : source_dir() / file;
  Loader loader(Home{source_dir()});
  LoadedScenario loaded = loader.load(p.string(), std::nullopt);
  std::vector<Scenario> out;
  for (auto& lp : loaded.points)
    out.push_back(std::move(lp.scenario));
  return out;
}

std::vector<Scenario> load_points_json(const json& doc, const fs::path& dir) {
  const fs::path file = dir / (doc.value("name", "scenario") + ".json");
  std::ofstream(file) << doc.dump(2);
  return load_points(file.string());
}

namespace {

json to_json(const IsolationResult& r) {
  return {{"time_us", r.time_us}, {"ipc", r.ipc}, {"mbps", r.mbps}};
}

IsolationResult from_json(const json& j) {
  return {j.at("time_us"), j.at("ipc"), j.at("mbps")};
}

class NullContext : public RunContext {
 public:
  void fallback(const std::string&, const std::string&) override {}
  void fact(const std::string&, const std::string&) override {}
  TraceSink* trace() override { return nullptr; }
  bool stop_requested() const override { return false; }
};

}  // namespace

IsolationResult isolation(const Scenario& s, const WorkloadInfo& w, int core) {
  return from_json(in_child([&] {
    NullContext ctx;
    sim::SimBackend backend(builtin_registry());
    return to_json(backend.isolation(s, w, core, 1, ctx));
  }));
}

json run_point_report(const Scenario& s, std::uint64_t seed) {
  TimeNs window = 0;
  json iso = json::object();
  const auto base = [&](const std::string& key, const WorkloadInfo& w, int core) {
    if (!iso.contains(key)) iso[key] = to_json(isolation(s, w, core));
  };
  for (const auto& n : s.nodes.rt)
    base("rt:" + n.name, n.workload, n.core);
  for (const auto& n : s.nodes.nrt)
    base("nrt:" + n.name, n.workload, n.core);
  if (!s.nodes.rt.empty())
    window = static_cast<TimeNs>(iso["rt:" + s.nodes.rt[0].name]["time_us"].get<double>() * 1e3);
  json out = in_child([&] {
    RegulationSetup reg = regulation_setup(s, builtin_registry());
    reg.params.monolithic_window_ns = window;
    const sim::RunConfig cfg = sim::point_config(s, std::move(reg), seed);
    const sim::SimReport rep = sim::simulate(cfg);
    json j;
    j["rt"] = json::array();
    for (const auto& r : rep.outcome.rt)
      j["rt"].push_back({{"name", r.name}, {"time_us", r.time_us}, {"jobs", r.jobs}});
    j["nrt"] = json::array();
    for (const auto& n : rep.outcome.nrt)
      j["nrt"].push_back({{"name", n.name},
                          {"time_us", n.time_us},
                          {"bandwidth_mbps", n.bandwidth_mbps},
                          {"throttle_count", n.throttle_count},
                          {"throttled_us", n.throttled_us},
                          {"runs", n.runs}});
    j["samples"] = json::array();
    for (const auto& o : rep.outcome.samples)
      j["samples"].push_back({o.kind, o.value_us});
    j["windows"] = json::array();
    for (const auto& w : rep.windows)
      j["windows"].push_back({{"entity", w.entity},
                              {"index", w.index},
                              {"start", w.start},
                              {"end", w.end},
                              {"bytes", w.bytes},
                              {"complete", w.complete}});
    j["end_ns"] = rep.end_ns;
    j["activations"] = rep.activations;
    return j;
  });
  out["isolation"] = iso;
  return out;
}

CliResult run_cli(const std::vector<std::string>& args) {
  std::string cmd = "cd '" + source_dir().string() + "' && ROSGUARD_HOME='" +
                    source_dir().string() + "' '" + ROSGUARD_TEST_BIN + "'";
  for (const auto& a : args)
    cmd += " '" + a + "'";
  cmd += " 2>&1";
  CliResult r;
  if (FILE* p = ::popen(cmd.c_str(), "r")) {
    char buf[4096];
    std::size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, p)) > 0)
      r.output.append(buf, n);
    const int status = ::pclose(p);
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  return r;
}

std::string read_text(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::vector<std::map<std::string, std::string>> read_csv(const fs::path& file) {
  std::vector<std::map<std::string, std::string>> rows;
  std::istringstream in(read_text(file));
  std::string line;
  std::vector<std::string> header;
  while (std::getline(in, line)) {
    const auto cells = csv_split(line);
    if (header.empty()) {
      header = cells;
      continue;
    }
    std::map<std::string, std::string> row;
    for (std::size_t i = 0; i < header.size() && i < cells.size(); ++i)
      row[header[i]] = cells[i];
    rows.push_back(std::move(row));
  }
  return rows;
}

double num(const std::map<std::string, std::string>& row, const std::string& column) {
  const auto it = row.find(column);
  INFO("column " << column);
  REQUIRE(it != row.end());
  REQUIRE(!it->second.empty());
  return std::stod(it->second);
}

}  // namespace rosguard::test

#include "commands.h"

#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <iomanip>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <utility>

#include "core/error.h"
#include "results/columns.h"

#ifdef ROSGUARD_WITH_HW
#include "hw/common/sys.h"
#include "hw/pmc_source/pmc_source.h"
#include "hw/throttle/throttle.h"
#endif

namespace rosguard {
namespace fs = std::filesystem;

namespace {

std::string seconds_text(double s) {
  std::ostringstream os;
  os << std::setprecision(3);
  if (s < 1e-3)
    os << s * 1e6 << " us";
  else if (s < 1.0)
    os << s * 1e3 << " ms";
  else
    os << s << " s";
  return os.str();
}

// The least simulated seconds per run over the sim points (min, max), if there are any.
std::optional<std::pair<double, double>> sim_time_range(const LoadedScenario& s) {
  std::optional<std::pair<double, double>> range;
  for (const auto& p : s.points)
    if (const auto t = p.scenario.backend == "sim" ? min_simulated_seconds(p.scenario)
                                                   : std::optional<double>())
      range = range ? std::make_pair(std::min(range->first, *t), std::max(range->second, *t))
                    : std::make_pair(*t, *t);
  return range;
}

// `rosguard check --json`: what the text summary says, as one JSON object.
nlohmann::json check_json(const LoadedScenario& s, const BackendRegistry& backends,
                          bool list_points) {
  const Scenario& first = s.points.front().scenario;
  nlohmann::json j = {
      {"file", s.file},
      {"valid", true},
      {"name", first.name},
      {"backend", first.backend},
      {"backend_built", backends.find(first.backend) != nullptr},
      {"platform", {{"name", first.platform.name}, {"origin", first.platform.origin}}},
      {"nodes",
       {{"rt", first.nodes.rt.size()},
        {"nrt", first.nodes.nrt.size()},
        {"controller_core", first.nodes.controller_core}}},
      {"sweep", nlohmann::json::array()},
      {"points", s.point_count},
      {"repetitions", first.repetitions},
      {"runs", s.point_count * static_cast<std::uint64_t>(first.repetitions)},
      {"points_checked", s.points.size()},
      {"policy_defaults", nlohmann::json::array()},
      {"warnings", s.warnings}};
  for (const auto& key : s.sweep_keys)
    j["sweep"].push_back({{"key", key}, {"values", s.expanded["sweep"][key].size()}});
  const auto range = sim_time_range(s);
  j["sim_seconds_min"] = range ? nlohmann::json(range->first) : nlohmann::json();
  j["sim_seconds_max"] = range ? nlohmann::json(range->second) : nlohmann::json();
  for (const auto& [what, points] : s.policy_defaults)
    j["policy_defaults"].push_back({{"default", what}, {"points", points}});
  if (list_points) {
    j["point_list"] = nlohmann::json::array();
    for (const auto& p : s.points) {
      nlohmann::json params = nlohmann::json::object();
      for (const auto& q : p.sweep.params)
        params[q.path] = q.value;
      j["point_list"].push_back({{"id", p.sweep.id}, {"parameters", params}});
    }
  }
  return j;
}

}  // namespace

int check_scenario(Loader& loader, const BackendRegistry& backends, const std::string& file,
                   const std::optional<std::string>& backend, bool list_points, bool json) {
  const LoadedScenario s =
      loader.load(file, backend, list_points ? PointSelection::All : PointSelection::Sample);
  const Scenario& first = s.points.front().scenario;
  if (const BackendInfo* info = backends.find(first.backend)) {
    const auto b = info->make();
    for (const auto& p : s.points)
      b->validate(p.scenario);
  }
  loader.print_warnings(s);
  // "platform": "host" on hw: what the probe could not find or use.
  if (s.host_platform.contains("hw"))
    for (const auto& note : s.host_platform["hw"]["probe"]["notes"])
      std::cerr << "note: host: " << note.get<std::string>() << "\n";
  if (json) {
    std::cout << check_json(s, backends, list_points).dump(2) << "\n";
    return 0;
  }

  std::string sweep;
  for (const auto& key : s.sweep_keys)
    sweep += (sweep.empty() ? "" : " x ") + key + " (" +
             std::to_string(s.expanded["sweep"][key].size()) + ")";
  const std::uint64_t runs = s.point_count * static_cast<std::uint64_t>(first.repetitions);
  std::cout << file << ": valid\n"
            << "  name         " << first.name << "\n"
            << "  backend      " << first.backend
            << (backends.find(first.backend) ? "" : " (not built into this rosguard)") << "\n"
            << "  platform     " << first.platform.name << " (" << first.platform.origin << ")\n"
            << "  nodes        " << first.nodes.rt.size() << " RT, " << first.nodes.nrt.size()
            << " nRT, controller on core " << first.nodes.controller_core << "\n"
            << "  sweep        " << (sweep.empty() ? "none" : sweep) << "\n"
            << "  repetitions  " << first.repetitions << " (" << runs << " runs)\n";
  if (const auto range = sim_time_range(s))
    std::cout << "  sim time     at least " << seconds_text(range->first)
              << (range->second > range->first ? " to " + seconds_text(range->second)
                                               : std::string())
              << " simulated per run (estimate: instructions / (base IPC x frequency), "
                 "without contention or isolation runs)\n";
  for (const auto& [what, points] : s.policy_defaults)
    std::cout << "  default      " << what << ", in " << points << " point"
              << (points == 1 ? "" : "s") << "\n";
  if (s.points.size() < s.point_count)
    std::cout << "  checked      " << s.points.size() << " of the " << s.point_count
              << " points (every value of every sweep key); run checks them all before "
                 "starting\n";
  if (list_points)
    for (const auto& p : s.points) {
      std::cout << "  " << p.sweep.id;
      for (const auto& q : p.sweep.params)
        std::cout << "  " << q.path << "="
                  << (q.value.is_string() ? q.value.get<std::string>() : q.value.dump());
      std::cout << "\n";
    }
  std::cout << s.point_count << " point" << (s.point_count == 1 ? "" : "s") << "\n";
  return 0;
}

int list_catalogue(const Loader& loader, const PolicyRegistry& policies,
                   const BackendRegistry& backends, const std::string& what) {
  if (what.empty()) {  // everything, one section after the other
    for (const char* kind : {"workloads", "platforms", "policies", "backends", "pmc-sources"}) {
      if (std::string(kind) != "workloads") std::cout << "\n";
      list_catalogue(loader, policies, backends, kind);
    }
    return 0;
  }
  const auto print = [](const std::string& name, const std::string& text) {
    std::cout << "  " << std::left << std::setw(18) << name << text << "\n";
  };
  if (what == "workloads") {
    std::cout << "workloads (" << loader.home().workloads().string() << "):\n";
    for (const auto& e : loader.workloads())
      print(e.name, e.summary);
  } else if (what == "platforms") {
    std::cout << "platforms (" << loader.home().platforms().string() << "):\n";
    for (const auto& e : loader.platforms())
      print(e.name, e.summary);
    std::string model;
    try {
      const fs::path path = host_model_path();
      std::error_code ec;
      model = path.string() + (fs::exists(path, ec) ? "" : ", not installed");
    } catch (const RunError& e) {
      model = e.what();
    }
    print(kHostPlatform,
          "(reserved) this machine: on hw probed when a scenario loads (rosguard platform "
          "probe shows it); on sim the installed calibrated model (" +
              model + ")");
  } else if (what == "columns") {
    // Markdown, as the README's results section shows it (tools/columns_doc.py).
    std::cout << "| `points.csv` column | unit | meaning |\n|---|---|---|\n";
    for (const auto& c : point_column_dictionary())
      std::cout << "| `" << c.name << "` | " << c.unit << " | " << c.meaning << " |\n";
    std::cout << "\n| `samples.csv` kind | unit | meaning |\n|---|---|---|\n";
    for (const auto& c : sample_kind_dictionary())
      std::cout << "| `" << c.name << "` | " << c.unit << " | " << c.meaning << " |\n";
  } else if (what == "policies") {
    std::cout << "policies:\n";
    for (const auto& p : policies.all()) {
      std::string how;
      if (p.traits.regulates) {
        for (Sampling m : p.traits.samplings)
          how += (how.empty() ? " (sampling: " : ", ") + std::string(to_string(m));
        how += ")";
      }
      print(p.name, p.description + how);
    }
  } else if (what == "backends") {
    std::cout << "backends:\n";
    for (const auto& b : backends.all())
      print(b.name, b.description);
    if (backends.all().empty()) std::cout << "  (none built)\n";
  } else if (what == "pmc-sources") {
    // The hw backend's counter sources, and whether each works on this host.
#ifdef ROSGUARD_WITH_HW
    hw::PmcSourceRegistry sources;
    hw::register_builtin(sources);
    std::cout << "pmc sources (hw backend; hw.pmc_source \"auto\" picks perf, else instrumented, "
                 "else software):\n";
    for (const auto& info : sources.all()) {
      const auto src = info.make();
      const auto why = src->unavailable_reason();
      std::string events;
      for (const auto& e : src->events())
        events += (events.empty() ? "" : ", ") + e;
      print(info.name, info.description);
      print("", why ? "unavailable here: " + *why : "available here: " + events);
    }
#else
    std::cout << "pmc sources: (the hw backend is not built into this rosguard)\n";
#endif
  } else if (what == "throttles") {
    // How a throttled nRT core can be held here, each measured (only when asked for: ~0.2 s each).
#ifdef ROSGUARD_WITH_HW
    const int core = hw::usable_cpus().back();
    std::cout << "throttles (hw.throttle; measured on CPU " << core
              << ": a worker's progress while throttled / nominal, 6 windows of 20 ms):\n";
    const auto fifo_err = hw::fifo_refused();
    std::string no_freezer;
    const bool freezer = hw::freezer_root(&no_freezer).has_value();
    for (const auto kind :
         {hw::ThrottleKind::Fifo, hw::ThrottleKind::Idle, hw::ThrottleKind::Freezer}) {
      const std::string name(hw::to_string(kind));
      if (kind == hw::ThrottleKind::Freezer && !freezer) {
        print(name, "unavailable here: " + no_freezer);
        continue;
      }
      const auto m = hw::measure_hold(kind, core);
      std::ostringstream line;
      if (std::isnan(m.hold_fraction))
        line << m.detail;
      else
        line << std::fixed << std::setprecision(3) << "hold " << 100.0 * m.hold_fraction
             << " % of nominal progress, activation " << std::setprecision(0) << m.activation_us
             << " us (worker CPU share unthrottled " << std::setprecision(2) << m.nominal_cpu_share
             << ")";
      if (kind == hw::ThrottleKind::Fifo && fifo_err)
        line << "; SCHED_FIFO refused (" << *fifo_err << "): THR ran at a nice value";
      print(name, line.str());
    }
#else
    std::cout << "throttles: (the hw backend is not built into this rosguard)\n";
#endif
  } else {
    throw InputError("", "",
                     "cannot list '" + what +
                         "': choose workloads, platforms, policies, backends, pmc-sources, "
                         "throttles or columns");
  }
  return 0;
}

int run_analysis(const Home& home, const std::vector<std::string>& args) {
  const fs::path package = home.root / "analysis" / "__main__.py";
  std::error_code ec;
  if (!fs::exists(package, ec))
    throw RunError("the analysis package is not in this tree (" + package.string() +
                   " is missing)");
  std::string python = "/usr/bin/python3";
  if (const char* env = std::getenv("ROSGUARD_PYTHON"); env && *env) python = env;

  std::vector<std::string> argv_s = {python, "-m", "analysis"};
  argv_s.insert(argv_s.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argv_s)
    argv.push_back(a.data());
  argv.push_back(nullptr);

  std::cout.flush();
  const pid_t pid = ::fork();
  if (pid < 0) throw RunError(std::string("fork: ") + std::strerror(errno));
  if (pid == 0) {
    const char* old = std::getenv("PYTHONPATH");
    const std::string path = home.root.string() + (old && *old ? ":" + std::string(old) : "");
    ::setenv("PYTHONPATH", path.c_str(), 1);
    ::setenv("MPLBACKEND", "Agg", 0);
    ::setenv("PYTHONDONTWRITEBYTECODE", "1", 0);  // no __pycache__ inside the source tree
    ::execv(argv[0], argv.data());
    std::cerr << "error: cannot start " << python << ": " << std::strerror(errno)
              << " (set ROSGUARD_PYTHON to a Python 3 with numpy, pandas, matplotlib and scipy)\n";
    ::_exit(1);
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  return 1;
}

}  // namespace rosguard

#include "commands/check.h"

#include <algorithm>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <utility>

#include "commands/command.h"

namespace rosguard {
namespace {

struct CheckArgs {
  std::string file, backend;
  bool points = false;
  bool json = false;
};

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

CommandHandler setup_check(CLI::App& sub) {
  auto args = std::make_shared<CheckArgs>();
  sub.add_option("scenario", args->file, "Scenario JSON file")->required();
  sub.add_option("--backend", args->backend, "Check as if run on this backend")
      ->check(CLI::IsMember({"sim", "hw"}));
  sub.add_flag("--points", args->points, "List every point's id and parameters");
  sub.add_flag("--json", args->json,
               "Print the summary as one JSON object (keys: file, valid, name, backend, "
               "backend_built, platform, nodes, sweep, points, repetitions, runs, "
               "points_checked, sim_seconds_min, sim_seconds_max, policy_defaults, warnings; "
               "point_list with --points); an invalid scenario prints nothing on stdout");
  return [args](const CommandContext& c) {
    return check_scenario(
        c.loader, c.backends, data_argument(c, args->file),
        args->backend.empty() ? std::nullopt : std::optional<std::string>(args->backend),
        args->points, args->json);
  };
}

}  // namespace rosguard

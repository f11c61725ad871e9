#include "commands/check.h"

#include <algorithm>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "commands/command.h"

namespace rosguard {
namespace {

struct CheckArgs {
  std::string file, backend;
  bool points = false;
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

}  // namespace

int check_scenario(Loader& loader, const BackendRegistry& backends, const std::string& file,
                   const std::optional<std::string>& backend, bool list_points) {
  const LoadedScenario s =
      loader.load(file, backend, list_points ? PointSelection::All : PointSelection::Sample);
  const Scenario& first = s.points.front().scenario;
  if (const BackendInfo* info = backends.find(first.backend)) {
    const auto b = info->make();
    for (const auto& p : s.points)
      b->validate(p.scenario);
  }
  for (const auto& w : s.warnings)
    if (!loader.printed(w)) std::cerr << "warning: " << w << "\n";
  // "platform": "host" on hw: what the probe could not find or use.
  if (s.host_platform.contains("hw"))
    for (const auto& note : s.host_platform["hw"]["probe"]["notes"])
      std::cerr << "note: host: " << note.get<std::string>() << "\n";

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
  std::optional<double> lo, hi;
  for (const auto& p : s.points)
    if (const auto t = p.scenario.backend == "sim" ? min_simulated_seconds(p.scenario)
                                                   : std::optional<double>()) {
      lo = std::min(lo.value_or(*t), *t);
      hi = std::max(hi.value_or(*t), *t);
    }
  if (lo)
    std::cout << "  sim time     at least " << seconds_text(*lo)
              << (*hi > *lo ? " to " + seconds_text(*hi) : std::string())
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
  return [args](const CommandContext& c) {
    return check_scenario(
        c.loader, c.backends, args->file,
        args->backend.empty() ? std::nullopt : std::optional<std::string>(args->backend),
        args->points);
  };
}

}  // namespace rosguard

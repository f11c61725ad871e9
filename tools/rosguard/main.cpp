// rosguard: simulate (sim), run (hw) and analyse memory-bandwidth regulation for ROS2-style
// mixed-criticality applications. Only this file turns errors into exit codes:
// 0 success, 1 runtime failure, 2 invalid input (usage or scenario), 130 / 143 interrupted.
#include <CLI/CLI.hpp>
#include <iostream>
#include <optional>
#include <regex>

#include "commands.h"
#include "core/error.h"
#include "loader.h"
#include "runner.h"
#include "version.h"

namespace {

constexpr const char* kFooter = R"(
Start here:
  rosguard check scenarios/quickstart.json    validate a scenario, count its points
  rosguard run scenarios/quickstart.json      sweep it on the sim backend
  rosguard plot results/quickstart            draw its figures
Run 'rosguard <command> --help' for the options of a command.)";

std::string joined_args(int argc, char** argv) {
  std::string s;
  for (int i = 0; i < argc; ++i)
    s += (i ? " " : "") + std::string(argv[i]);
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace rosguard;

  CLI::App app{"rosguard " + std::string(kVersion) +
               ": simulate, run and analyse memory-bandwidth regulation (ROSGuard)\n"
               "for ROS2-style mixed-criticality applications on multicore SoCs."};
  app.footer(kFooter);
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("rosguard ") + kVersion);

  RunOptions run_opt;
  std::string shard;
  std::string backend_opt;
  auto* run = app.add_subcommand("run", "Run every point of a scenario and write results.");
  run->add_option("scenario", run_opt.scenario_file, "Scenario JSON file")->required();
  run->add_option("--backend", backend_opt, "Backend to run on (default: the scenario's)")
      ->check(CLI::IsMember({"sim", "hw"}));
  run->add_option("--out", run_opt.out, "Results folder (default: results/<scenario name>)");
  run->add_option("--jobs", run_opt.jobs, "Worker processes for sim (default: all CPUs)")
      ->check(CLI::PositiveNumber);
  run->add_option("--shard", shard,
                  "Run only shard I of N (points with index % N == I); shards may share --out");
  run->add_flag("--resume", run_opt.resume, "Continue a run in --out, skipping finished points");
  run->add_flag("--overwrite", run_opt.overwrite, "Replace the results already in --out");
  run->add_flag("--trace", run_opt.trace,
                "Also write trace.json (Chrome trace, opens in Perfetto)");
  run->add_flag("--quiet", run_opt.quiet, "No progress or summary");
  run->footer("Writes manifest.json, points.csv and samples.csv (DESIGN.md section 7).");

  std::string check_file, check_backend;
  bool check_points = false;
  auto* check = app.add_subcommand("check", "Validate a scenario and print its number of points.");
  check->add_option("scenario", check_file, "Scenario JSON file")->required();
  check->add_option("--backend", check_backend, "Check as if run on this backend")
      ->check(CLI::IsMember({"sim", "hw"}));
  check->add_flag("--points", check_points, "List every point's id and parameters");

  std::string plot_dir, plot_out;
  auto* plot = app.add_subcommand("plot", "Draw every figure a results folder supports.");
  plot->add_option("results", plot_dir, "Results folder of a run")->required();
  plot->add_option("--out", plot_out, "Figure folder (default: RESULTS/figures)");

  std::string cmp_a, cmp_b, cmp_out;
  auto* compare =
      app.add_subcommand("compare", "Compare two results folders point by point (e.g. sim vs hw).");
  compare->add_option("results_a", cmp_a, "Reference results folder (e.g. measured)")->required();
  compare->add_option("results_b", cmp_b, "Results folder compared with it (e.g. simulated)")
      ->required();
  compare->add_option("--out", cmp_out, "Output folder (default: RESULTS_B/compare)");

  std::string list_what;
  auto* list =
      app.add_subcommand("list", "List workloads, platforms, policies, backends or pmc-sources.");
  list->add_option("kind", list_what,
                   "workloads | platforms | policies | backends | pmc-sources (default: all)")
      ->check(CLI::IsMember({"workloads", "platforms", "policies", "backends", "pmc-sources"}));

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }

  try {
    PolicyRegistry policies;
    register_builtin(policies);
    BackendRegistry backends;
    register_backends(backends, policies);
    Loader loader(Home::locate());

    if (*run) {
      if (!backend_opt.empty()) run_opt.backend = backend_opt;
      if (!shard.empty()) {
        std::smatch m;
        const std::regex re(R"((\d+)/(\d+))");
        if (!std::regex_match(shard, m, re) || std::stoi(m[2]) < 1 ||
            std::stoi(m[1]) >= std::stoi(m[2]))
          throw InputError("", "",
                           "--shard must be I/N with 0 <= I < N, e.g. 0/2 (got '" + shard + "')");
        run_opt.shard_index = std::stoi(m[1]);
        run_opt.shard_count = std::stoi(m[2]);
      }
      if (run_opt.resume && run_opt.overwrite)
        throw InputError("", "", "--resume and --overwrite contradict each other; choose one");
      run_opt.command_line = joined_args(argc, argv);
      return run_scenario(run_opt, loader, backends);
    }
    if (*check)
      return check_scenario(
          loader, backends, check_file,
          check_backend.empty() ? std::nullopt : std::optional<std::string>(check_backend),
          check_points);
    if (*list) return list_catalogue(loader, policies, backends, list_what);
    if (*plot) {
      std::vector<std::string> args = {"plot", plot_dir};
      if (!plot_out.empty()) args.insert(args.end(), {"--out", plot_out});
      return run_analysis(loader.home(), args);
    }
    if (*compare) {
      std::vector<std::string> args = {"compare", cmp_a, cmp_b};
      if (!cmp_out.empty()) args.insert(args.end(), {"--out", cmp_out});
      return run_analysis(loader.home(), args);
    }
  } catch (const InputError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  } catch (const RunError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "error: internal: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

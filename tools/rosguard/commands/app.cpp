#include "commands/app.h"

#include <iostream>
#include <string>
#include <utility>
#include <vector>

#include "backends.h"
#include "commands/command.h"
#include "core/error.h"
#include "store/results_store.h"
#include "version.h"

namespace rosguard {
namespace {

// In the order `rosguard --help` lists them.
constexpr Subcommand kCommands[] = {
    {"run", "Run every point of a scenario and write results.", setup_run},
    {"tune",
     "Search a scenario's regulation space in sim for the setting that keeps every RT node "
     "within a slowdown bound and gives the nRT nodes the most progress.",
     setup_tune},
    {"check", "Validate a scenario and print its number of points.", setup_check},
    {"status",
     "Show how far a run is: points and runs done per shard and overall, the shards that failed "
     "or still run (also on Slurm), and the commands that re-run a failed shard; for a tune's "
     "folder, its batches and what it chose.",
     setup_status},
    {"plot", "Draw every figure a results folder supports.", setup_plot},
    {"compare", "Compare two results folders point by point (e.g. sim vs hw).", setup_compare},
    {"list",
     "List workloads, platforms, policies, backends, pmc-sources, throttles or the result "
     "columns.",
     setup_list},
    {"calibrate", "Measure this host and fit the sim platform model to it.", setup_calibrate},
    {"platform", "Describe this machine as a platform.", setup_platform},
    {"profile",
     "Run a program under valgrind's lackey and write a sim workload profile from its memory "
     "trace (L2 refills and write-backs per kilo-instruction, miss-ratio curve, per phase).",
     setup_profile},
    {"guard",
     "Regulate the processes pinned to the configured nRT cores of this machine while RT nodes "
     "are active, until SIGINT / SIGTERM (every core back to nominal, exit 0); SIGHUP reloads "
     "the configuration.",
     setup_guard},
};

constexpr const char* kFooter = R"(
Start here:
  rosguard check scenarios/quickstart.json    validate a scenario, count its points
  rosguard run scenarios/quickstart.json      sweep it on the sim backend
  rosguard status results/quickstart          how far a run (or a Slurm job) is
  rosguard plot results/quickstart            draw its figures
  rosguard tune scenarios/examples/tune.json --rt-slowdown-max 1.2
                                              the setting that keeps RT within 1.2x
These run from any folder: a scenario or guard configuration that the working folder does not
hold is read from rosguard's data (ROSGUARD_HOME below), and results/ is written in the working
folder. The docs are in that data folder too: README.md and docs/ (also man rosguard).
Run 'rosguard <command> --help' for the options of a command.
Environment:
  ROSGUARD_HOME=DIR      the data (scenarios/, analysis/): an install's share/rosguard or a
                         source tree (default: ../share/rosguard beside the executable, else the
                         source tree it was built from)
  ROSGUARD_PYTHON=PATH   the Python that plot, compare and calibrate's figures run (default
                         /usr/bin/python3); it needs numpy, pandas, matplotlib and scipy)";

std::string joined_args(int argc, char** argv) {
  std::string s;
  for (int i = 0; i < argc; ++i)
    s += (i ? " " : "") + std::string(argv[i]);
  return s;
}

// The top-level options: description, footer, --version.
void describe_app(CLI::App& app) {
  app.description("rosguard " + std::string(kVersion) +
                  ": simulate, run and analyse memory-bandwidth regulation (ROSGuard)\n"
                  "for ROS2-style mixed-criticality applications on multicore SoCs.");
  app.footer(kFooter);
  app.require_subcommand(1);
  // Baked in at configure time (version.h): the same revision the manifests record.
  app.set_version_flag("--version", std::string("rosguard ") + kVersion +
                                        "\ngit revision: " + kGitRevision +
                                        "\nbuild type: " + kBuildType + "\ncompiler: " + kCompiler +
                                        "\nbackends: " + kBackendsBuilt);
}

// Wires up the registries and the loader, then runs the handler; the only place that turns
// errors into exit codes.
int run_handler(const CommandHandler& handler, const std::string& command_line) {
  try {
    PolicyRegistry policies;
    register_builtin(policies);
    BackendRegistry backends;
    register_backends(backends, policies);
    Loader loader(Home::locate());
    return handler(CommandContext{loader, policies, backends, command_line});
  } catch (const InputError& e) {
    for (const auto& problem : e.problems())
      std::cerr << "error: " << problem << "\n";
    return 2;
  } catch (const ShardBusyError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 4;
  } catch (const RunError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "error: internal: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace

int run_cli(int argc, char** argv) {
  CLI::App app{"", "rosguard"};  // the name in usage lines, however it was started
  describe_app(app);
  std::vector<std::pair<CLI::App*, CommandHandler>> subcommands;
  for (const Subcommand& command : kCommands) {
    CLI::App* sub = app.add_subcommand(command.name, command.help);
    subcommands.emplace_back(sub, command.setup(*sub));
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }
  for (const auto& [sub, handler] : subcommands)
    if (*sub) return run_handler(handler, joined_args(argc, argv));
  return 0;
}

}  // namespace rosguard

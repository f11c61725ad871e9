// rosguard: simulate (sim), run (hw) and analyse memory-bandwidth regulation for ROS2-style
// mixed-criticality applications. Only this file turns errors into exit codes:
// 0 success, 1 runtime failure, 2 invalid input (usage or scenario), 4 the shard of the results
// folder is being written by another rosguard (run), 130 / 143 interrupted.
#include <CLI/CLI.hpp>
#include <charconv>
#include <climits>
#include <iostream>
#include <optional>
#include <tuple>
#include <utility>

#include "calibrate.h"
#include "commands.h"
#include "core/error.h"
#include "guard_cmd.h"
#include "host_model.h"
#include "loader.h"
#include "profile.h"
#include "results_store.h"
#include "runner.h"
#include "slurm.h"
#include "status.h"
#include "tune.h"
#include "version.h"

namespace {

constexpr const char* kFooter = R"(
Start here:
  rosguard check scenarios/quickstart.json    validate a scenario, count its points
  rosguard run scenarios/quickstart.json      sweep it on the sim backend
  rosguard status results/quickstart          how far a run (or a Slurm job) is
  rosguard plot results/quickstart            draw its figures
  rosguard tune scenarios/examples/tune.json --rt-slowdown-max 1.2
                                              the setting that keeps RT within 1.2x
Run 'rosguard <command> --help' for the options of a command.
Environment:
  ROSGUARD_HOME=DIR      the data (scenarios/, analysis/): an install's share/rosguard or a
                         source tree (default: ../share/rosguard beside the executable, else the
                         source tree it was built from)
  ROSGUARD_PYTHON=PATH   the Python that plot, compare and calibrate's figures run (default
                         /usr/bin/python3); it needs numpy, pandas, matplotlib and scipy)";

// "I/N" with 0 <= I < N <= INT_MAX, digits only; throws InputError otherwise.
std::pair<int, int> parse_shard(const std::string& text) {
  const auto slash = text.find('/');
  const auto number = [&](std::size_t begin, std::size_t end, int& value) {
    const char* first = text.data() + begin;
    const char* last = text.data() + end;
    const auto [ptr, ec] = std::from_chars(first, last, value);
    return first != last && *first != '-' && *first != '+' && ec == std::errc() && ptr == last;
  };
  int index = 0, count = 0;
  if (slash == std::string::npos || !number(0, slash, index) ||
      !number(slash + 1, text.size(), count) || count < 1 || index >= count)
    throw rosguard::InputError("", "",
                               "--shard must be I/N with 0 <= I < N <= " + std::to_string(INT_MAX) +
                                   ", e.g. 0/2 (got '" +
                                   (text.size() > 40 ? text.substr(0, 40) + "..." : text) + "')");
  return {index, count};
}

std::string joined_args(int argc, char** argv) {
  std::string s;
  for (int i = 0; i < argc; ++i)
    s += (i ? " " : "") + std::string(argv[i]);
  return s;
}

struct RunArgs {
  rosguard::RunOptions options;
  std::string shard;    // "I/N", parsed by run_command
  std::string backend;  // empty: the scenario's
  bool slurm = false;
  bool no_unregulated = false;
  rosguard::SlurmOptions slurm_options;
};

CLI::App* add_run_command(CLI::App& app, RunArgs& args) {
  rosguard::RunOptions& opt = args.options;
  auto* run = app.add_subcommand("run", "Run every point of a scenario and write results.");
  run->add_option("scenario", opt.scenario_file, "Scenario JSON file")->required();
  run->add_option("--backend", args.backend, "Backend to run on (default: the scenario's)")
      ->check(CLI::IsMember({"sim", "hw"}));
  run->add_option("--out", opt.out, "Results folder (default: results/<scenario name>)");
  run->add_option("--jobs", opt.jobs, "Worker processes for sim (default: all CPUs)")
      ->check(CLI::Range(1, 65536));
  run->add_option("--shard", args.shard,
                  "Run only shard I of N (points with index % N == I); shards may share --out, "
                  "also at the same time (one writer per shard: a second one exits 4)");
  run->add_flag("--resume", opt.resume, "Continue a run in --out, skipping finished points");
  run->add_flag("--overwrite", opt.overwrite, "Replace the results already in --out");
  run->add_flag("--trace", opt.trace, "Also write trace.json (Chrome trace, opens in Perfetto)");
  run->add_flag("--quiet", opt.quiet, "No progress or summary");
  run->add_flag("--no-unregulated", args.no_unregulated,
                "Do not measure the unregulated co-run (the nodes with policy none, once per "
                "workload pair and cores) that fills the *_unregulated_* columns");
  run->add_flag("--slurm", args.slurm,
                "Submit the run to Slurm (sbatch) as an array job, one shard per task, all "
                "writing into --out on a filesystem the nodes share; prints the job id");
  run->add_option("--array", args.slurm_options.array,
                  "With --slurm: the number of array tasks, i.e. shards (default: one per point, "
                  "at most " +
                      std::to_string(rosguard::kDefaultSlurmShards) + ")")
      ->check(CLI::Range(1, INT_MAX));
  run->add_option("--sbatch-arg", args.slurm_options.sbatch_args,
                  "With --slurm: one more sbatch option for the script, written as an #SBATCH "
                  "line; repeat it (e.g. --sbatch-arg=--partition=short "
                  "--sbatch-arg=--time=30)")
      ->allow_extra_args(false);
  run->add_flag("--dry-run", args.slurm_options.dry_run,
                "With --slurm: print the sbatch script; write and submit nothing");
  run->footer(
      "Writes manifest.json, points.csv and samples.csv (docs/design.md, results format).\n"
      "Exit codes: 0 done, 1 a run or a write failed (the manifest records the error), 2 invalid "
      "input\n(nothing is written), 4 another rosguard is writing the same shard into --out "
      "(nothing is written;\none writer per shard), 130 / 143 interrupted (continue with "
      "--resume).\n"
      "With --slurm the script goes to OUT/slurm/run.sbatch, the tasks' logs to "
      "OUT/slurm/JOB_TASK.out;\nfollow the run with 'rosguard status OUT', which also prints how "
      "to re-run a failed shard.");
  return run;
}

int run_command(RunArgs& args, const std::string& command_line, rosguard::Loader& loader,
                const rosguard::BackendRegistry& backends) {
  rosguard::RunOptions& opt = args.options;
  if (!args.backend.empty()) opt.backend = args.backend;
  if (!args.shard.empty()) std::tie(opt.shard_index, opt.shard_count) = parse_shard(args.shard);
  if (opt.resume && opt.overwrite)
    throw rosguard::InputError("", "",
                               "--resume and --overwrite contradict each other; choose one");
  opt.command_line = command_line;
  opt.unregulated = !args.no_unregulated;
  if (!args.slurm) {
    for (const auto& [given, name] :
         {std::pair{args.slurm_options.array > 0, "--array"},
          std::pair{!args.slurm_options.sbatch_args.empty(), "--sbatch-arg"},
          std::pair{args.slurm_options.dry_run, "--dry-run"}})
      if (given) throw rosguard::InputError("", "", std::string(name) + " goes with --slurm");
    return rosguard::run_scenario(opt, loader, backends);
  }
  if (!args.shard.empty())
    throw rosguard::InputError("", "",
                               "--shard and --slurm contradict each other: --slurm runs every "
                               "shard, one per array task (--array N)");
  return rosguard::submit_to_slurm(opt, args.slurm_options, loader, backends);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace rosguard;

  CLI::App app{"rosguard " + std::string(kVersion) +
                   ": simulate, run and analyse memory-bandwidth regulation (ROSGuard)\n"
                   "for ROS2-style mixed-criticality applications on multicore SoCs.",
               "rosguard"};  // the name in usage lines, however it was started
  app.footer(kFooter);
  app.require_subcommand(1);
  // Baked in at configure time (version.h): the same revision the manifests record.
  app.set_version_flag("--version", std::string("rosguard ") + kVersion +
                                        "\ngit revision: " + kGitRevision +
                                        "\nbuild type: " + kBuildType + "\ncompiler: " + kCompiler +
                                        "\nbackends: " + kBackendsBuilt);

  RunArgs run_args;
  auto* run = add_run_command(app, run_args);

  TuneOptions tune_opt;
  std::string tune_confirm;
  auto* tune = app.add_subcommand(
      "tune",
      "Search a scenario's regulation space in sim for the setting that keeps every RT node "
      "within a slowdown bound and gives the nRT nodes the most progress.");
  tune->add_option("scenario", tune_opt.scenario_file, "Scenario JSON file")->required();
  tune->add_option("--rt-slowdown-max", tune_opt.rt_slowdown_max,
                   "The bound X: every RT node's slowdown (co-run time / time alone) <= X, "
                   "in every case (e.g. 1.05)")
      ->required();
  tune->add_option("--objective", tune_opt.objective,
                   "What the nRT nodes get: nrt-throughput (lowest nRT slowdown, the mean over "
                   "nRT nodes, repetitions and cases; default)")
      ->check(CLI::IsMember({"nrt-throughput"}));
  tune->add_option("--confirm", tune_confirm,
                   "hw: re-measure the winner and the unregulated co-run on this machine and "
                   "print them beside the sim prediction")
      ->check(CLI::IsMember({"hw"}));
  tune->add_option("--thresholds", tune_opt.thresholds,
                   "The threshold ladder to search, in % (e.g. 1,2,4,8,16,32), instead of the "
                   "scenario's regulation.threshold_pct list or the default 1 .. 100 %")
      ->delimiter(',');
  tune->add_option("--out", tune_opt.out, "Results folder (default: results/<scenario name>/tune)");
  tune->add_option("--jobs", tune_opt.jobs, "Worker processes for sim (default: all CPUs)")
      ->check(CLI::Range(1, 65536));
  tune->add_flag("--overwrite", tune_opt.overwrite, "Replace an earlier tune in --out");
  tune->add_flag("--quiet", tune_opt.quiet, "No progress on stderr");
  tune->footer(
      "The space: the scenario's swept regulation keys (policy, sampling, periods, ..., joined "
      "keys too; an unswept key keeps the scenario's value, else the policy's default); when it "
      "sweeps none but the threshold, the policies that throttle x each sampling mode they run "
      "with "
      "x periods 100/1000, 500/2500, 1000/5000 us and the policy's own default pair. Thresholds: "
      "--thresholds, else the swept "
      "regulation.threshold_pct, else 1 .. 100 % (17 rungs). Other sweep keys are cases the "
      "setting must meet together. "
      "Per configuration the threshold is bisected (RT slowdown grows, nRT slowdown falls with "
      "it); a configuration whose probes contradict that is scanned, with a note.\n"
      "Writes OUT/tune.json, OUT/points.csv (every simulated setting; rosguard plot OUT) and "
      "OUT/probes/ (unregulated/, step-NN/: one run folder per batch; rosguard status OUT "
      "follows them). Exit 0: a setting meets the bound; 1: none does (the closest is printed); 2: "
      "invalid input.");

  std::string check_file, check_backend;
  bool check_points = false, check_json = false;
  auto* check = app.add_subcommand("check", "Validate a scenario and print its number of points.");
  check->add_option("scenario", check_file, "Scenario JSON file")->required();
  check->add_option("--backend", check_backend, "Check as if run on this backend")
      ->check(CLI::IsMember({"sim", "hw"}));
  check->add_flag("--points", check_points, "List every point's id and parameters");
  check->add_flag("--json", check_json,
                  "Print the summary as one JSON object (keys: file, valid, name, backend, "
                  "backend_built, platform, nodes, sweep, points, repetitions, runs, "
                  "points_checked, sim_seconds_min, sim_seconds_max, policy_defaults, warnings; "
                  "point_list with --points); an invalid scenario prints nothing on stdout");

  std::string status_dir;
  auto* status = app.add_subcommand(
      "status",
      "Show how far a run is: points and runs done per shard and overall, the shards that failed "
      "or still run (also on Slurm), and the commands that re-run a failed shard; for a tune's "
      "folder, its batches and what it chose.");
  status->add_option("results", status_dir, "Results folder of a run or a tune (its --out)")
      ->required();
  bool status_json = false;
  status->add_flag(
      "--json", status_json,
      "Print it as one JSON object, \"kind\": \"run\" (folder, scenario_file, points, "
      "repetitions, shards [shard, points_done, points_total, runs_done, runs_total, state, live], "
      "points_done, runs_done, runs_total, state, rerun [shard, command], slurm_queue_error) or "
      "\"tune\" (folder, command, batches [name, started, points_done, points, runs_done, "
      "runs_total, state], points_done, points, runs_done, runs_total, state, stopped, finished, "
      "and tune.json's rt_slowdown_max, best, closest, runner_up, unregulated: null before it is "
      "written)");
  status->footer(
      "Reads DIR/manifest.json, DIR/points.csv and, after --slurm, DIR/slurm/job.json "
      "and squeue. A tune's folder (DIR/tune.json or DIR/probes/): one row per batch "
      "(probes/unregulated, probes/step-NN, confirm-hw) with its points, runs and state, the "
      "tune's state (running, between batches, stopped: run it again with --overwrite, "
      "finished) and, finished, its best setting. Exit 0; 2 when DIR is not a results folder.");

  std::string plot_dir, plot_out, plot_rt_max;
  auto* plot = app.add_subcommand("plot", "Draw every figure a results folder supports.");
  plot->add_option("results", plot_dir, "Results folder of a run")->required();
  plot->add_option("--out", plot_out, "Figure folder (default: RESULTS/figures)");
  plot->add_option("--rt-slowdown-max", plot_rt_max,
                   "Draw this RT slowdown bound (e.g. 1.05) as a target on every RT slowdown "
                   "figure and the trade-off figure (default: DIR/tune.json's, if any)");

  std::string cmp_a, cmp_b, cmp_out;
  std::vector<std::string> cmp_band;
  auto* compare =
      app.add_subcommand("compare", "Compare two results folders point by point (e.g. sim vs hw).");
  compare->add_option("results_a", cmp_a, "Reference results folder (e.g. measured)")->required();
  compare->add_option("results_b", cmp_b, "Results folder compared with it (e.g. simulated)")
      ->required();
  compare->add_option("--out", cmp_out, "Output folder (default: RESULTS_B/compare)");
  compare
      ->add_option("--band", cmp_band,
                   "A results folder of B's scenario on a band platform of B's model (rosguard "
                   "calibrate writes them into band/); repeat it, one per platform. B's "
                   "prediction band (min..max over B and these) goes into compare.csv, "
                   "summary.json, the summary and the scatter")
      ->allow_extra_args(false);

  std::string list_what;
  auto* list = app.add_subcommand("list",
                                  "List workloads, platforms, policies, backends, pmc-sources, "
                                  "throttles or the result columns.");
  list->add_option("kind", list_what,
                   "workloads | platforms | policies | backends | pmc-sources (default: all of "
                   "these) | throttles (measures each here) | columns")
      ->check(CLI::IsMember({"workloads", "platforms", "policies", "backends", "pmc-sources",
                             "throttles", "columns"}));

  CalibrateOptions cal;
  auto* calibrate =
      app.add_subcommand("calibrate", "Measure this host and fit the sim platform model to it.");
  calibrate->add_flag("--quick", cal.quick,
                      "The short suite (a few working sets, fewer repetitions; minutes)");
  calibrate->add_option("--out", cal.out,
                        "Output folder: platform.json, calibration.json, figures/ "
                        "(default: results/calibration)");
  calibrate->add_flag("--install", cal.install,
                      "Also save platform.json as this host's model, which \"platform\": "
                      "\"host\" uses in sim");
  calibrate
      ->add_option("--from", cal.from,
                   "Refit the measurements of an earlier calibration.json (measures nothing)")
      ->check(CLI::ExistingFile);
  calibrate->add_option("--name", cal.name, "Name of the fitted platform (default: host)");
  calibrate->add_flag("--quiet", cal.quiet, "No progress");
  calibrate
      ->add_option("--transport", cal.transport,
                   "Topic transport whose message costs are measured: inproc (default) or dds "
                   "(Cyclone DDS with ROS 2 names, as hw.transport dds)")
      ->check(CLI::IsMember({"inproc", "dds"}));
  calibrate->add_flag("--strict", cal.strict,
                      "Refuse the fit when a parameter rests mostly on its prior (default: write "
                      "the model, name such parameters with their uncertainty)");
  calibrate->footer(
      "Runs built-in kernels alone and against co-runners on this host's cores (hw backend), "
      "times the middleware and OS costs, fits the memory model and the cost distributions by "
      "non-linear least squares (Eigen), and refuses a fit that does not converge.");

  std::string probe_out;
  auto* platform = app.add_subcommand("platform", "Describe this machine as a platform.");
  platform->require_subcommand(1);
  auto* probe = platform->add_subcommand(
      "probe",
      "Probe this machine (usable CPUs, clusters sharing a last-level cache, caches, frequency, "
      "the PMU events that open, SCHED_FIFO) and print it as a platform JSON: what \"platform\": "
      "\"host\" uses on the hw backend.");
  probe->add_option("--out", probe_out, "Write the platform JSON to this file (atomically)");
  probe->footer(
      "Reference, memory model and costs come from the installed host model (rosguard calibrate "
      "--install) when there is one; otherwise the reference bandwidth is measured now "
      "(bandwidth_read, under a second) and there is no memory model, so the sim backend "
      "cannot run the result. Notes on what is missing or not usable go to stderr.");
  auto* model_cmd = platform->add_subcommand(
      "model",
      "Say whether the installed host model (rosguard calibrate --install) was measured on this "
      "machine: its CPU model, usable CPUs, caches and kernel against this machine's.");
  model_cmd->footer(
      "Exit status 0 when it was; 3 when no model is installed, the model was measured on another "
      "machine (what differs is printed), or it does not record its machine (calibrated before "
      "rosguard wrote \"measured_on\"). make validate recalibrates then.");

  ProfileOptions prof;
  auto* profile_cmd = app.add_subcommand(
      "profile",
      "Run a program under valgrind's lackey and write a sim workload profile from its memory "
      "trace (L2 refills and write-backs per kilo-instruction, miss-ratio curve, per phase).");
  profile_cmd->add_option("--out", prof.out, "Workload JSON to write (atomically)")->required();
  profile_cmd
      ->add_option("--slice-instructions", prof.slice_instructions,
                   "Instructions per slice (default 2000000: about 1 ms at 2 GHz and IPC "
                   "1); adjacent similar slices are merged into phases")
      ->check(CLI::PositiveNumber);
  profile_cmd
      ->add_option("--max-instructions", prof.max_instructions,
                   "Stop after this many instructions (default: the whole run)")
      ->check(CLI::PositiveNumber);
  profile_cmd
      ->add_option("--skip-instructions", prof.skip_instructions,
                   "Run this many instructions through the caches first, uncounted (e.g. "
                   "a program's start-up); --max-instructions counts from there")
      ->check(CLI::PositiveNumber);
  profile_cmd->add_option("--caches", prof.caches_kb,
                          "L1,L2,L3 capacities in KB of the target (default 64,256,2048)");
  profile_cmd->add_option("--ways", prof.ways,
                          "L1,L2,L3 associativity (default 4,8,16: Cortex-A78AE L1D and L2, "
                          "DSU-AE L3)");
  profile_cmd->add_option("--name", prof.name, "Workload name (default: the program's file name)");
  profile_cmd->add_option("--slices-csv", prof.slices_csv,
                          "Also write each slice's counts (CSV: first instruction, loads, stores, "
                          "refills, write-backs, L3 misses per MRC capacity) to this file");
  profile_cmd->add_flag("--quiet", prof.quiet, "No progress or summary");
  profile_cmd->add_option("command", prof.command, "-- PROGRAM ARGS...")->required();
  profile_cmd->footer(
      "Needs valgrind (Debian package valgrind). lackey is slow: it writes each trace line with "
      "its own "
      "system call (about 3 M instructions per CPU second here, some 1000x the program alone); "
      "--max-instructions bounds a long run. "
      "base_ipc is written as a placeholder: fit "
      "it against measured IPC. Exit 1 when the program fails, with its status.");

  GuardArgs guard_args;
  auto* guard_cmd = app.add_subcommand(
      "guard",
      "Regulate the processes pinned to the configured nRT cores of this machine while RT nodes "
      "are active, until SIGINT / SIGTERM (every core back to nominal, exit 0); SIGHUP reloads "
      "the configuration.");
  guard_cmd->add_option("config", guard_args.config, "Guard configuration (guard.schema.json)")
      ->required();
  guard_cmd->add_flag("--check", guard_args.check,
                      "Validate the configuration, print it with its defaults; nothing runs");

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

    if (*run) return run_command(run_args, joined_args(argc, argv), loader, backends);
    if (*status) return results_status(status_dir, status_json);
    if (*tune) {
      tune_opt.confirm = tune_confirm;
      tune_opt.command_line = joined_args(argc, argv);
      return tune_scenario(tune_opt, loader, backends, policies);
    }
    if (*check)
      return check_scenario(
          loader, backends, check_file,
          check_backend.empty() ? std::nullopt : std::optional<std::string>(check_backend),
          check_points, check_json);
    if (*guard_cmd) return guard_command(guard_args, SchemaSet(loader.home().schemas()), policies);
    if (*profile_cmd) return profile_command(prof, SchemaSet(loader.home().schemas()));
    if (*calibrate) return calibrate_host(cal, loader);
    if (*list) return list_catalogue(loader, policies, backends, list_what);
    if (*probe) return platform_probe_command(SchemaSet(loader.home().schemas()), probe_out);
    if (*model_cmd) return platform_model_command(SchemaSet(loader.home().schemas()));
    if (*plot) {
      std::vector<std::string> args = {"plot", plot_dir};
      if (!plot_out.empty()) args.insert(args.end(), {"--out", plot_out});
      if (!plot_rt_max.empty()) args.insert(args.end(), {"--rt-slowdown-max", plot_rt_max});
      return run_analysis(loader.home(), args);
    }
    if (*compare) {
      std::vector<std::string> args = {"compare", cmp_a, cmp_b};
      if (!cmp_out.empty()) args.insert(args.end(), {"--out", cmp_out});
      for (const auto& band : cmp_band)
        args.insert(args.end(), {"--band", band});
      return run_analysis(loader.home(), args);
    }
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
  return 0;
}

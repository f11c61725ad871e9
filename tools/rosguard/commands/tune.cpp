// `rosguard tune SCENARIO --rt-slowdown-max X`: the regulation setting that meets the bound
// (tune/tune.h).
#include "tune/tune.h"

#include "commands/command.h"

namespace rosguard {

CommandHandler setup_tune(CLI::App& sub) {
  auto options = std::make_shared<TuneOptions>();
  TuneOptions& opt = *options;
  sub.add_option("scenario", opt.scenario_file, "Scenario JSON file")->required();
  sub.add_option("--rt-slowdown-max", opt.rt_slowdown_max,
                 "The bound X: every RT node's slowdown (co-run time / time alone) <= X, "
                 "in every case (e.g. 1.05)")
      ->required();
  sub.add_option("--objective", opt.objective,
                 "What the nRT nodes get: nrt-throughput (lowest nRT slowdown, the mean over "
                 "nRT nodes, repetitions and cases; default)")
      ->check(CLI::IsMember({"nrt-throughput"}));
  sub.add_option("--confirm", opt.confirm,
                 "hw: re-measure the winner and the unregulated co-run on this machine and "
                 "print them beside the sim prediction")
      ->check(CLI::IsMember({"hw"}));
  sub.add_option("--thresholds", opt.thresholds,
                 "The threshold ladder to search, in % (e.g. 1,2,4,8,16,32), instead of the "
                 "scenario's regulation.threshold_pct list or the default 1 .. 100 %")
      ->delimiter(',');
  sub.add_option("--out", opt.out, "Results folder (default: results/<scenario name>/tune)");
  sub.add_option("--jobs", opt.jobs, "Worker processes for sim (default: all CPUs)")
      ->check(CLI::Range(1, 65536));
  sub.add_option("--deployable", opt.deployable,
                 "guard: search only the settings `rosguard guard` deploys (external sampling, "
                 "periods from 100 us, budgets by threshold; each setting left out is noted with "
                 "the reason)")
      ->check(CLI::IsMember({"guard"}));
  sub.add_option("--emit-guard", opt.emit_guard,
                 "Write the best setting as a guard configuration to this file (for `rosguard "
                 "guard FILE`; implies --deployable guard)");
  sub.add_flag("--overwrite", opt.overwrite, "Replace an earlier tune in --out");
  sub.add_flag("--quiet", opt.quiet, "No progress on stderr");
  sub.footer(
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
      "follows them); with --emit-guard, the guard configuration (rosguard guard FILE --check). "
      "Exit 0: a setting meets the bound; 1: none does (the closest is printed, no guard "
      "configuration is written); 2: invalid input.");
  return [options](const CommandContext& c) {
    options->command_line = c.command_line;
    options->scenario_file = data_argument(c, options->scenario_file);
    return tune_scenario(*options, c.loader, c.backends, c.policies);
  };
}

}  // namespace rosguard

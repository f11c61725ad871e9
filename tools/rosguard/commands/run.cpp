// `rosguard run SCENARIO`: every point of a scenario, here (run/runner.h) or as a Slurm array
// job (run/slurm.h).
#include <charconv>
#include <climits>
#include <string>
#include <tuple>
#include <utility>

#include "commands/command.h"
#include "core/error.h"
#include "run/runner.h"
#include "run/slurm.h"

namespace rosguard {
namespace {

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
    throw InputError("", "",
                     "--shard must be I/N with 0 <= I < N <= " + std::to_string(INT_MAX) +
                         ", e.g. 0/2 (got '" +
                         (text.size() > 40 ? text.substr(0, 40) + "..." : text) + "')");
  return {index, count};
}

struct RunArgs {
  RunOptions options;
  std::string shard;    // "I/N", parsed by run_command
  std::string backend;  // empty: the scenario's
  bool slurm = false;
  bool no_unregulated = false;
  SlurmOptions slurm_options;
};

void add_run_arguments(CLI::App& run, RunArgs& args) {
  RunOptions& opt = args.options;
  run.add_option("scenario", opt.scenario_file, "Scenario JSON file")->required();
  run.add_option("--backend", args.backend, "Backend to run on (default: the scenario's)")
      ->check(CLI::IsMember({"sim", "hw"}));
  run.add_option("--out", opt.out, "Results folder (default: results/<scenario name>)");
  run.add_option("--jobs", opt.jobs, "Worker processes for sim (default: all CPUs)")
      ->check(CLI::Range(1, 65536));
  run.add_option("--shard", args.shard,
                 "Run only shard I of N (points with index % N == I); shards may share --out, "
                 "also at the same time (one writer per shard: a second one exits 4)");
  run.add_flag("--resume", opt.resume, "Continue a run in --out, skipping finished points");
  run.add_flag("--overwrite", opt.overwrite, "Replace the results already in --out");
  run.add_flag("--trace", opt.trace, "Also write trace.json (Chrome trace, opens in Perfetto)");
  run.add_flag("--quiet", opt.quiet, "No progress or summary");
  run.add_flag("--no-unregulated", args.no_unregulated,
               "Do not measure the unregulated co-run (the nodes with policy none, once per "
               "workload pair and cores) that fills the *_unregulated_* columns");
  run.add_flag("--slurm", args.slurm,
               "Submit the run to Slurm (sbatch) as an array job, one shard per task, all "
               "writing into --out on a filesystem the nodes share; prints the job id");
  run.add_option("--array", args.slurm_options.array,
                 "With --slurm: the number of array tasks, i.e. shards (default: one per point, "
                 "at most " +
                     std::to_string(kDefaultSlurmShards) + ")")
      ->check(CLI::Range(1, INT_MAX));
  run.add_option("--sbatch-arg", args.slurm_options.sbatch_args,
                 "With --slurm: one more sbatch option for the script, written as an #SBATCH "
                 "line; repeat it (e.g. --sbatch-arg=--partition=short "
                 "--sbatch-arg=--time=30)")
      ->allow_extra_args(false);
  run.add_flag("--dry-run", args.slurm_options.dry_run,
               "With --slurm: print the sbatch script; write and submit nothing");
  run.footer(
      "Writes manifest.json, points.csv and samples.csv (docs/design.md, results format).\n"
      "Exit codes: 0 done, 1 a run or a write failed (the manifest records the error), 2 invalid "
      "input\n(nothing is written), 4 another rosguard is writing the same shard into --out "
      "(nothing is written;\none writer per shard), 130 / 143 interrupted (continue with "
      "--resume).\n"
      "With --slurm the script goes to OUT/slurm/run.sbatch, the tasks' logs to "
      "OUT/slurm/JOB_TASK.out;\nfollow the run with 'rosguard status OUT', which also prints how "
      "to re-run a failed shard.");
}

int run_command(RunArgs& args, const std::string& command_line, Loader& loader,
                const BackendRegistry& backends) {
  RunOptions& opt = args.options;
  if (!args.backend.empty()) opt.backend = args.backend;
  if (!args.shard.empty()) std::tie(opt.shard_index, opt.shard_count) = parse_shard(args.shard);
  if (opt.resume && opt.overwrite)
    throw InputError("", "", "--resume and --overwrite contradict each other; choose one");
  opt.command_line = command_line;
  opt.unregulated = !args.no_unregulated;
  if (!args.slurm) {
    for (const auto& [given, name] :
         {std::pair{args.slurm_options.array > 0, "--array"},
          std::pair{!args.slurm_options.sbatch_args.empty(), "--sbatch-arg"},
          std::pair{args.slurm_options.dry_run, "--dry-run"}})
      if (given) throw InputError("", "", std::string(name) + " goes with --slurm");
    opt.process_ends = true;
    return run_scenario(opt, loader, backends);
  }
  if (!args.shard.empty())
    throw InputError("", "",
                     "--shard and --slurm contradict each other: --slurm runs every "
                     "shard, one per array task (--array N)");
  return submit_to_slurm(opt, args.slurm_options, loader, backends);
}

}  // namespace

CommandHandler setup_run(CLI::App& sub) {
  auto args = std::make_shared<RunArgs>();
  add_run_arguments(sub, *args);
  return [args](const CommandContext& c) {
    args->options.scenario_file = data_argument(c, args->options.scenario_file);
    return run_command(*args, c.command_line, c.loader, c.backends);
  };
}

}  // namespace rosguard

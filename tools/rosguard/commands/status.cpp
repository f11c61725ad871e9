// `rosguard status DIR`: how far a run or a tune is (store/status.h).
#include "store/status.h"

#include "commands/command.h"

namespace rosguard {

CommandHandler setup_status(CLI::App& sub) {
  auto dir = std::make_shared<std::string>();
  sub.add_option("results", *dir, "Results folder of a run or a tune (its --out)")->required();
  auto json = std::make_shared<bool>(false);
  sub.add_flag(
      "--json", *json,
      "Print it as one JSON object, \"kind\": \"run\" (folder, scenario_file, points, "
      "repetitions, shards [shard, points_done, points_total, runs_done, runs_total, state, live], "
      "points_done, runs_done, runs_total, state, rerun [shard, command], slurm_queue_error) or "
      "\"tune\" (folder, command, batches [name, started, points_done, points, runs_done, "
      "runs_total, state], points_done, points, runs_done, runs_total, state, stopped, finished, "
      "and tune.json's rt_slowdown_max, best, closest, runner_up, unregulated: null before it is "
      "written)");
  sub.footer(
      "Reads DIR/manifest.json, DIR/points.csv and, after --slurm, DIR/slurm/job.json "
      "and squeue. A tune's folder (DIR/tune.json or DIR/probes/): one row per batch "
      "(probes/unregulated, probes/step-NN, confirm-hw) with its points, runs and state, the "
      "tune's state (running, between batches, stopped: run it again with --overwrite, "
      "finished) and, finished, its best setting. Exit 0; 2 when DIR is not a results folder.");
  return [dir, json](const CommandContext&) { return results_status(*dir, *json); };
}

}  // namespace rosguard

// `rosguard status DIR`: how far a results folder's run is, per shard and overall, read from
// DIR/manifest.json (its "shards" entries: status, error, host, pid, slurm_job), DIR/points.csv
// (the rows, one per run) and, for a run submitted with --slurm, DIR/slurm/job.json and Slurm's
// queue (squeue). A tune's folder (rosguard tune: DIR/tune.json or DIR/probes/) is read batch
// by batch: each batch is a run folder. Reads only; takes no lock (a row being appended is not
// counted yet). Called from main() only.
#pragma once

#include <filesystem>

namespace rosguard {

// Prints the per-shard table (points and runs done / total, state: complete, failed, running,
// pending, stopped when a shard's process is gone without finishing, not started), the folder's
// total, and the commands that re-run the shards that did not finish (with --resume: the runs
// already in points.csv are skipped, nothing is written twice). For a tune's folder: the tune's
// command, one row per batch (probes/unregulated, probes/step-NN, confirm-hw: points and runs
// done / total, state), the tune's state (running a batch, between batches, stopped with how to
// run it again, finished) and, once finished, what it searched and chose (tune.json). Returns
// 0; throws InputError (exit 2) when `dir` is not a results folder. `as_json`: the same as one
// JSON object on stdout: "kind" "run" (folder, scenario_file, points, repetitions, shards (each:
// shard, points_done, points_total, runs_done, runs_total, state, live), points_done,
// runs_done, runs_total, state, rerun (each: shard, command), slurm_queue_error) or "tune"
// (folder, command, batches (each: name, started, points_done, points, runs_done, runs_total,
// state), points_done, points, runs_done, runs_total, state, stopped, finished, and tune.json's
// rt_slowdown_max, best, closest, runner_up, unregulated: null until it is written).
int results_status(const std::filesystem::path& dir, bool as_json);

}  // namespace rosguard

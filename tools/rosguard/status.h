// `rosguard status DIR`: how far a results folder's run is, per shard and overall, read from
// DIR/manifest.json (its "shards" entries: status, error, host, pid, slurm_job), DIR/points.csv
// (the rows, one per run) and, for a run submitted with --slurm, DIR/slurm/job.json and Slurm's
// queue (squeue). Reads only; takes no lock (a row being appended is not counted yet).
// Called from main() only.
#pragma once

#include <filesystem>

namespace rosguard {

// Prints the per-shard table (points and runs done / total, state: complete, failed, running,
// pending, stopped when a shard's process is gone without finishing, not started), the folder's
// total, and the commands that re-run the shards that did not finish (with --resume: the runs
// already in points.csv are skipped, nothing is written twice). Returns 0; throws InputError
// (exit 2) when `dir` is not a results folder.
int results_status(const std::filesystem::path& dir);

}  // namespace rosguard

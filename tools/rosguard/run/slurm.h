// `rosguard run S.json --slurm`: a run as one Slurm array job, one shard per array task, every
// task writing into the same results folder on a filesystem the nodes share (the results store
// takes turns under DIR/.lock, see results_store.h). Called from main() only, in the main thread.
//
// The submission writes DIR/slurm/run.sbatch (absolute paths: this rosguard executable, the
// scenario, DIR; logs DIR/slurm/JOBID_TASK.out) and DIR/slurm/job.json, and submits the script
// with `sbatch --parsable`. Every task runs `rosguard run S --out DIR --shard TASK/N --resume`:
// a task that is run again (sbatch --array=I DIR/slurm/run.sbatch) skips the runs already in
// points.csv, so nothing is written twice.
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "backend/backend.h"
#include "load/loader.h"
#include "run/runner.h"

namespace rosguard {

struct SlurmOptions {
  int array = 0;                         // array tasks = shards; 0: one per point, at most 64
  std::vector<std::string> sbatch_args;  // written as "#SBATCH ARG" lines, after rosguard's own
  bool dry_run = false;                  // print the script, write and submit nothing
};

// The default number of shards: one per point (a shard holds whole points), at most this many.
inline constexpr int kDefaultSlurmShards = 64;

// What the script needs; every path absolute.
struct SbatchScriptInputs {
  std::filesystem::path rosguard;  // this executable
  std::filesystem::path scenario;
  std::filesystem::path out;
  std::string job_name;
  int shards = 1;
  std::optional<int> jobs;  // --jobs for each task; empty: the task's CPUs
  std::optional<std::string> backend;
  bool trace = false;
  bool unregulated = true;  // false: --no-unregulated
  std::vector<std::string> sbatch_args;
  std::string summary;  // one comment line: what the job runs
};

// The sbatch array script (bash). Paths are shell-quoted in the command; the #SBATCH lines are
// not shell code, so check_sbatch_word() must accept DIR and every sbatch argument first.
std::string sbatch_script(const SbatchScriptInputs& in);

// Throws InputError when `word` cannot stand in an #SBATCH line as written (sbatch splits those
// lines at whitespace and reads no shell quoting; '%' in a log path is a pattern).
void check_sbatch_word(const std::string& what, const std::string& word, bool is_path);

// Validates the scenario as `run` would and submits it (or prints the script with --dry-run).
// Exit code 0; throws InputError (exit 2) for bad input, RunError (exit 1) when sbatch is
// missing or refuses the job.
int submit_to_slurm(const RunOptions& run, const SlurmOptions& slurm, Loader& loader,
                    const BackendRegistry& backends);

// A job (or one array task) in Slurm's queue.
struct SlurmTask {
  std::string id;       // "JOBID_TASK" for an array task, else "JOBID"
  long long job = 0;    // JOBID (of the array: the same for all its tasks)
  int index = -1;       // TASK; -1 for a job that is no array (or a range not split yet)
  std::string state;    // PENDING, RUNNING, COMPLETED, FAILED, CANCELLED, ...
  std::string reason;   // why pending, or why it ended
  std::string command;  // the batch script
};

// Every job in Slurm's queue, one entry per array task (squeue -r -t all: also those that
// ended in the last MinJobAge seconds). nullopt with `why` when squeue is missing or fails.
std::optional<std::vector<SlurmTask>> slurm_queue(std::string& why);

// Slurm states in which a job's processes may still run (or will).
bool slurm_state_live(const std::string& state);

// The shell form of a word: as is when it needs no quoting, else in single quotes.
std::string shell_quote(const std::string& word);

}  // namespace rosguard

// The tasks of a run and the pool that runs them.
//
// A task is one isolation baseline or one point x repetition. A backend that needs a process
// per task (sim: SystemC elaborates once per process) runs each task in a worker forked by a
// task host: a process the runner forks before it builds the sweep's points (Loader::load_base,
// then load_points), so that it stays small and each fork copies little (forking the runner
// itself, which holds every point of a 10,000-point sweep, made copy_page_range the largest
// part of the runner's CPU time). The runner sends each task to the host over a Unix socket
// with the write end of a pipe; the host forks a worker, which builds its task's point again
// (Loader::point, from the same scenario text the runner checked) and sends its TaskResult
// (task_pool.cpp: encode) through the pipe straight to the runner, then leaves with _exit. The
// host reaps the workers and reports each exit status. Other backends (hw: one point at a time on
// the machine) run tasks in this process. Only the runner's thread calls an Executor.
//
// Containment: the host and every worker die with their parent (PR_SET_PDEATHSIG: SIGKILL), the
// host ignores SIGINT / SIGTERM (the runner decides: it asks the host to stop its workers with
// SIGTERM), and workers take the default handlers back (a terminal's Ctrl-C reaches them).
#pragma once

#include <sys/types.h>

#include <cstddef>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "backend/backend.h"
#include "load/loader.h"
#include "run/unregulated.h"
#include "scenario/scenario.h"

namespace rosguard {

struct Task {
  enum class Kind { Isolation, Point } kind = Kind::Point;
  std::size_t point = 0;  // index into the loaded points (isolation: a point that uses it)
  int rep = 0;            // isolation: which measurement of the baseline
  std::string iso_key;    // isolation only: Baselines::key
  const WorkloadInfo* workload = nullptr;  // isolation only
  int core = 0;                            // isolation only
  // A point task that runs the unregulated co-run (unregulated.h) of the point: a worker
  // process rebuilds the point from its sweep index and runs UnregulatedCoruns::scenario_of it.
  bool corun = false;
};

struct TaskResult {
  bool ok = false;
  bool interrupted = false;
  std::string error;
  IsolationResult iso;
  PointOutcome outcome;
  std::vector<std::pair<std::string, std::string>> fallbacks;  // (what, detail)
  std::map<std::string, std::string> facts;
  nlohmann::json trace = nlohmann::json::array();  // Chrome trace events with --trace
  // A point run in a worker process: its samples.csv lines and its points.csv row, made there
  // (samples_rows, points_row with RunState::header and the baselines the worker had: the
  // runner then only appends them), and `outcome` left empty.
  bool rows_made = false;
  std::string samples_csv;
  std::string row_csv;
};

// What every task reads; the runner fills `baselines` and `coruns` before the point tasks start.
struct RunState {
  const LoadedScenario* loaded = nullptr;
  Backend* backend = nullptr;
  Baselines baselines;
  bool trace = false;
  std::vector<std::string> header;  // points.csv's columns
  UnregulatedCoruns coruns;
};

// A point run's samples.csv lines and points.csv row: as its worker made them, else from its
// outcome (samples_rows, then points_row and fill_unregulated_cells with `state`'s header,
// baselines and co-runs).
std::pair<std::string, std::string> run_rows(const TaskResult& result, const LoadedPoint& point,
                                             int rep, const RunState& state);

// "point ID rep R (path=value, ...)": how progress and errors name a run.
std::string point_label(const SweepPoint& point, int rep);

// Runs one task on the backend; every error becomes a TaskResult (never throws).
TaskResult execute(const Task& task, const RunState& state);
// The same for a point `lp` built in this process: an isolation task without its `workload`
// finds it among the point's nodes by `iso_key` and `core`.
TaskResult execute(const Task& task, const LoadedPoint& lp, Backend& backend,
                   const Baselines& baselines, bool trace);

// What a task in a worker reads: the baselines and co-runs the runner had when it sent the
// task, and points.csv's columns.
struct TaskInputs {
  Baselines baselines;
  UnregulatedCoruns coruns;
  std::vector<std::string> header;
};

// What a worker of a task host runs: the task (its `workload` is null: pointers do not cross
// processes) with its inputs.
using TaskFunction = std::function<TaskResult(const Task& task, const TaskInputs& inputs)>;

// The task host process (see the top of this file). Forked by the constructor, which returns
// in the runner; the host runs `warm_up` once (e.g. reading the platform and workload files
// every worker needs), then forks a worker per task that calls `run`. The destructor closes
// the socket: the host stops its workers (SIGTERM), reaps them and exits; it is reaped here.
class TaskHost {
 public:
  // `others`: the hosts made before this one, whose sockets the new host must not hold (a
  // host ends when the runner's end of its socket closes).
  TaskHost(std::function<void()> warm_up, TaskFunction run,
           const std::vector<std::unique_ptr<TaskHost>>& others = {});
  ~TaskHost();
  TaskHost(const TaskHost&) = delete;
  TaskHost& operator=(const TaskHost&) = delete;

  int socket() const { return sock_; }
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
  int sock_ = -1;
};

// Workers per task host. A host forks and reaps its workers one after another: about 0.22 ms of
// CPU per task on the development VM, against about 1.8 ms per sim point in the worker, so one
// host could feed about 8 workers and no more; with 4 it stays under half busy.
constexpr int kWorkersPerHost = 4;

// The task hosts for `base` (from Loader::load_base: no point built yet) when its backend
// needs a process per task: one per kWorkersPerHost of `jobs` workers, at most one per CPU
// online; else none (also when the
// backend is not built in: the runner says so later). Each worker builds its task's point with
// `loader` (Loader::point, without checking the schema again: the runner checks every point)
// and runs it on a backend its host makes.
std::vector<std::unique_ptr<TaskHost>> start_task_hosts(Loader& loader, const LoadedScenario& base,
                                                        const BackendRegistry& backends, bool trace,
                                                        int jobs);

class Executor {
 public:
  virtual ~Executor() = default;
  virtual bool can_submit() const = 0;
  // Starts task `id` (the caller's index, handed back by wait_one).
  virtual void submit(std::size_t id, const Task& task) = 0;
  virtual bool busy() const = 0;
  // Blocks until a task finishes; returns its id and result.
  virtual std::pair<std::size_t, TaskResult> wait_one() = 0;
  // Stops every running task (SIGTERM to workers) and reaps them.
  virtual void stop_all() = 0;
};

// Up to max(1, jobs) workers at a time through `hosts` (their share each; a task goes to the
// host with the fewest in flight) when `process_per_task` (a host is then required:
// ContractError without one), else one task at a time in this process.
std::unique_ptr<Executor> make_executor(const RunState& state, bool process_per_task, int jobs,
                                        const std::vector<TaskHost*>& hosts = {});

}  // namespace rosguard

// The tasks of a run and the pool that runs them.
//
// A task is one isolation baseline or one point x repetition. A backend that needs a process
// per task (sim: SystemC elaborates once per process) gets a ForkExecutor: up to `jobs` forked
// workers, each running one task and sending its TaskResult back as JSON over a pipe, then
// leaving with _exit (no parent destructors run in the child). Other backends (hw: one point at
// a time on the machine) run tasks in this process. Only the runner's thread calls an Executor.
#pragma once

#include <cstddef>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "backend/backend.h"
#include "loader.h"

namespace rosguard {

struct Task {
  enum class Kind { Isolation, Point } kind = Kind::Point;
  std::size_t point = 0;  // index into the loaded points (isolation: a point that uses it)
  int rep = 0;            // isolation: which measurement of the baseline
  std::string iso_key;    // isolation only: Baselines::key
  const WorkloadInfo* workload = nullptr;  // isolation only
  int core = 0;                            // isolation only
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
};

// What every task reads; the runner fills `baselines` before the point tasks start.
struct RunState {
  const LoadedScenario* loaded = nullptr;
  Backend* backend = nullptr;
  Baselines baselines;
  bool trace = false;
};

// "point ID rep R (path=value, ...)": how progress and errors name a run.
std::string point_label(const SweepPoint& point, int rep);

// Runs one task on the backend; every error becomes a TaskResult (never throws).
TaskResult execute(const Task& task, const RunState& state);

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

// A ForkExecutor with max(1, jobs) workers when `process_per_task`, else in-process.
std::unique_ptr<Executor> make_executor(const RunState& state, bool process_per_task, int jobs);

}  // namespace rosguard

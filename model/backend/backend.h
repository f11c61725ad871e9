// The interface both backends implement, and what they return.
//
// Contract: the runner (tools/rosguard/run/runner.h) calls isolation() baseline_repetitions() times
// per distinct (workload, core) of a run (each call one measurement), interleaved with
// run_point() for every point and repetition (docs/design.md, section 5). A backend whose
// process_per_task() is true gets each call in a fresh worker process (SystemC can elaborate
// only once per process); otherwise calls come one at a time from the runner's main thread.
// Times are microseconds as doubles; bandwidths are Eq. 1 MB/s.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "backend/trace.h"
#include "core/registry.h"
#include "scenario/scenario.h"

namespace rosguard {

// One unregulated isolation run of a workload on a core (the paper's Table 1 quantities).
struct IsolationResult {
  double time_us = 0.0;
  double ipc = 0.0;
  double mbps = 0.0;
};

// Every measurement of one isolation baseline, by measurement index (0, 1, ...), and what the
// results use of them: the median, and the spread of the isolation time.
struct BaselineRuns {
  // A baseline whose isolation time varies more than this (coefficient of variation) is too
  // noisy for the slowdowns measured against it: regulation effects of a few percent (the
  // paper's differences between policies) would be lost in it.
  static constexpr double kNoisyCv = 0.05;

  std::map<int, IsolationResult> runs;

  int count() const { return static_cast<int>(runs.size()); }
  // Field by field median of the measurements (NaN fields ignored; NaN when none is finite).
  IsolationResult median() const;
  // Sample standard deviation / mean of the isolation times; NaN with fewer than two.
  double time_cv() const;
  bool too_noisy() const { return time_cv() > kNoisyCv; }
  // What to tell the user about baseline `key` when it is too noisy; empty otherwise.
  std::string noise_warning(const std::string& key) const;
};

// Before which repetition round (0 .. repetitions-1) of the points measurement k of a baseline
// measured `measurements` times runs: floor(k x repetitions / measurements). With as many
// measurements as repetitions, one before each round; with more, the extra ones go to the first
// rounds; the first is always before round 0, and every measurement before the last round.
int baseline_round(int k, int repetitions, int measurements);

// Isolation results of a run, keyed by workload identity and core.
class Baselines {
 public:
  // Identity of an isolation run: the workload, the core, and everything else that can change
  // its result (platform, backend and backend settings; not how often it is measured); with
  // hw.adjacent_baselines the point itself too: each point has baselines of its own.
  static std::string key(const Scenario& scenario, const WorkloadInfo& workload, int core);
  // Records measurement `rep` of baseline `key` (replacing an earlier one of the same index).
  void put(const std::string& key, IsolationResult result, int rep = 0) {
    by_key_[key].runs[rep] = result;
  }
  // The median of a baseline's measurements. Throws RunError naming the missing key.
  IsolationResult at(const Scenario& scenario, const WorkloadInfo& workload, int core) const;
  // Every measurement of a baseline. Throws RunError naming the missing key.
  const BaselineRuns& runs(const Scenario& scenario, const WorkloadInfo& workload, int core) const;
  const std::map<std::string, BaselineRuns>& all() const { return by_key_; }

 private:
  std::map<std::string, BaselineRuns> by_key_;
};

struct RtOutcome {
  std::string name;
  double time_us = 0.0;  // mean job time (start to finish) over the node's iterations
  int jobs = 0;
  // Each finished job's response time (release to finish; released at its period's start, or
  // when the previous job finished when the node has no period), in job order.
  std::vector<double> response_us;
  // Jobs whose response time exceeded the period (the implicit deadline); -1 without a period.
  int deadline_misses = -1;
};

struct NrtOutcome {
  std::string name;
  // Time one run of the workload took: measured for `once`; for `loop`, the window divided by
  // the isolation runs the work done in it is worth (the isolation time of exactly that work
  // over the isolation time of one run; model/engine/outcome.h), so that the slowdown compares
  // the same work whatever the workload's phases.
  double time_us = 0.0;
  double bandwidth_mbps = 0.0;  // Eq. 1 while regulation was active (whole run when never active)
  std::uint64_t throttle_count = 0;
  double throttled_us = 0.0;
  double runs = 0.0;  // work done in the window, in runs (fractional; once: the share done)
};

// One observation for samples.csv. kind: activation_delay | pmc_callback | sampling_overhead |
// pmc_read | rt_job (samples_rows() writes these from RtOutcome::response_us: `rt_job` for the
// first RT node, `rt1_job`, ... for the others), or another name a backend documents.
struct Observation {
  std::string kind;
  double value_us = 0.0;
};

// The sampling a point ran with (RegulationSetup::sampling and sampling_period_ns): the
// scenario's, or what the backend ran in its place (a fallback it reported).
struct RanSampling {
  Sampling mode = Sampling::Self;
  TimeNs period_ns = 0;
};

struct PointOutcome {
  std::vector<RtOutcome> rt;    // in scenario order
  std::vector<NrtOutcome> nrt;  // in scenario order
  std::vector<Observation> samples;
  // What points.csv reports in its sampling columns; absent: the scenario's.
  std::optional<RanSampling> sampling;
};

// What a backend tells the runner besides results: fallbacks taken (these go to the manifest
// and to stderr, never silently) and facts about how it ran.
class RunContext {
 public:
  virtual ~RunContext() = default;
  // A fallback was taken: `what` is a short stable key ("sched_fifo"), `detail` the reason.
  virtual void fallback(const std::string& what, const std::string& detail) = 0;
  // A fact for the manifest ("pmc_source" -> "instrumented").
  virtual void fact(const std::string& key, const std::string& value) = 0;
  // Where to send trace events; null when --trace is off.
  virtual TraceSink* trace() = 0;
  // True once the user asked the run to stop (SIGINT / SIGTERM). A long task polls it, returns
  // its nodes to nominal and throws Interrupted.
  virtual bool stop_requested() const = 0;
};

// What a backend found or set up for a whole run (Backend::prepare_run), for the manifest: facts
// and fallbacks as a task's, warnings (also printed), and entries for the manifest's top level.
struct RunSetup {
  std::vector<std::pair<std::string, std::string>> fallbacks;  // (what, detail)
  std::map<std::string, std::string> facts;
  std::vector<std::string> warnings;
  nlohmann::json manifest = nlohmann::json::object();
};

class Backend {
 public:
  virtual ~Backend() = default;
  virtual std::string_view name() const = 0;
  virtual bool process_per_task() const = 0;
  // Whether repetitions of a point are measurements with noise, whose precision is reported
  // (the slowdown CI columns, the manifest's `precision`) and may be targeted (hw.precision_pct,
  // model/results/precision.h): hw. A deterministic backend (sim: repetitions differ only by
  // their seeds) says false: it runs the scenario's repetitions and leaves the CI cells empty.
  virtual bool judges_precision() const { return false; }
  // Called once by the runner before the first task of a run, on the thread that then calls
  // isolation() and run_point() (not for process_per_task() backends), with every point of the
  // run (this shard's). What it sets up lasts until the backend is destroyed. Default: nothing.
  virtual RunSetup prepare_run(const std::vector<const Scenario*>& points) {
    (void)points;
    return {};
  }
  // How many times each distinct isolation baseline of `scenario` is measured: 1 for a
  // deterministic backend (sim), several where the machine is noisy (hw).
  virtual int baseline_repetitions(const Scenario& scenario) const = 0;
  // Called for every point before anything is written, from several threads at once: throws
  // InputError (file + JSON path) for what this backend cannot run (e.g. a platform without a
  // memory model).
  virtual void validate(const Scenario& point) const = 0;
  // One measurement of a baseline (`seed` differs per measurement). Throws InputError for a
  // scenario this backend cannot run, RunError for failures.
  virtual IsolationResult isolation(const Scenario& scenario, const WorkloadInfo& workload,
                                    int core, std::uint64_t seed, RunContext& ctx) = 0;
  virtual PointOutcome run_point(const Scenario& point, const Baselines& baselines, int rep,
                                 std::uint64_t seed, RunContext& ctx) = 0;
};

struct BackendInfo {
  std::string name;
  std::string description;
  std::function<std::unique_ptr<Backend>()> make;
};

class BackendRegistry : public Registry<BackendInfo> {
 public:
  BackendRegistry() : Registry("backend") {}
};

// Seed of one task, independent of the order tasks run in: mixes the scenario seed with the
// point id (or isolation key) and the repetition.
std::uint64_t task_seed(std::uint64_t scenario_seed, std::string_view id, int rep);

}  // namespace rosguard

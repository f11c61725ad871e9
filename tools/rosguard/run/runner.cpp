#include "run/runner.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <functional>
#include <iostream>
#include <map>
#include <optional>
#include <set>

#include "core/error.h"
#include "load/files.h"
#include "results/precision.h"
#include "results/results.h"
#include "run/parallel.h"
#include "run/progress.h"
#include "run/stop_signal.h"
#include "run/task_pool.h"
#include "run/unregulated.h"
#include "store/results_store.h"
#include "store/run_manifest.h"

namespace rosguard {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// --jobs, or the CPUs online when it is 0.
int requested_jobs(const RunOptions& opt) {
  return opt.jobs > 0 ? opt.jobs : static_cast<int>(::sysconf(_SC_NPROCESSORS_ONLN));
}

// Threads for the work on every point before and between the tasks (parallel.h): --jobs, no
// more than the CPUs online.
unsigned worker_threads(const RunOptions& opt) {
  const auto cpus = static_cast<int>(::sysconf(_SC_NPROCESSORS_ONLN));
  return static_cast<unsigned>(std::max(1, std::min(requested_jobs(opt), cpus)));
}

// The run's backend, with every point validated against it (on `threads` threads).
std::unique_ptr<Backend> make_backend(const LoadedScenario& loaded, const BackendRegistry& backends,
                                      unsigned threads = 1) {
  const std::string& name = loaded.points.front().scenario.backend;
  const BackendInfo* info = backends.find(name);
  if (!info) {
    std::string known;
    for (const auto& b : backends.all())
      known += (known.empty() ? "" : ", ") + b.name;
    throw RunError("the " + name + " backend is not built into this rosguard (built: " +
                   (known.empty() ? "none" : known) + ")");
  }
  std::unique_ptr<Backend> backend = info->make();
  parallel_for(loaded.points.size(), threads,
               [&](std::size_t i) { backend->validate(loaded.points[i].scenario); });
  return backend;
}

std::vector<std::string> header_of(const LoadedScenario& loaded) {
  std::size_t max_rt = 0, max_nrt = 0;
  for (const auto& p : loaded.points) {
    max_rt = std::max(max_rt, p.scenario.nodes.rt.size());
    max_nrt = std::max(max_nrt, p.scenario.nodes.nrt.size());
  }
  return points_header(max_rt, max_nrt, loaded.sweep_paths);
}

std::string join(const std::vector<std::string>& v, const std::string& sep) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i)
    s += (i ? sep : "") + v[i];
  return s;
}

// The unregulated co-runs (unregulated.h) of a shard are points appended to the loaded scenario
// after the scenario's own (index >= first): they run as point tasks (on the policy-none copy of
// a point), after the baselines of their round and before its points, so that the rows are
// written with them.
struct CorunPlan {
  std::size_t first = 0;          // index of the first co-run point: the scenario's point count
  std::vector<int> measurements;  // per co-run point, as many as the baselines get
  std::map<std::string, std::string> key_of;  // this shard's point id -> its co-run key
  bool is_corun(std::size_t point) const { return point >= first; }
};

// How many times a co-run (and a baseline) is measured for a point: the backend's count, or with
// adaptive rounds the rounds every point runs (one per round).
using MeasurementCount = std::function<int(const Scenario&)>;

// Appends one point per distinct co-run key this shard's regulated points need (none with
// `opt.unregulated` off).
CorunPlan add_corun_points(LoadedScenario& loaded, const RunOptions& opt,
                           const MeasurementCount& measurements_of) {
  CorunPlan plan;
  plan.first = loaded.points.size();
  if (!opt.unregulated) return plan;
  std::map<std::string, std::size_t> index;  // key -> its co-run point
  std::vector<LoadedPoint> added;
  // Each point's co-run key ("" for none), on --jobs threads.
  std::vector<std::string> keys(plan.first);
  parallel_for(plan.first, worker_threads(opt), [&](std::size_t i) {
    const LoadedPoint& p = loaded.points[i];
    if (p.sweep.index % static_cast<std::size_t>(opt.shard_count) ==
            static_cast<std::size_t>(opt.shard_index) &&
        UnregulatedCoruns::needed(p.scenario))
      keys[i] = UnregulatedCoruns::key(p.scenario);
  });
  for (std::size_t i = 0; i < plan.first; ++i) {
    const LoadedPoint& p = loaded.points[i];
    if (keys[i].empty()) continue;
    const std::string& key = plan.key_of[p.sweep.id] = keys[i];
    const int measurements = measurements_of(p.scenario);
    auto [it, fresh] = index.try_emplace(key, added.size());
    if (fresh) {
      LoadedPoint corun;
      // The source point's sweep index: a worker process rebuilds the co-run from it
      // (Task::corun), as it rebuilds a point from its own.
      corun.sweep.index = p.sweep.index;
      corun.sweep.id = key;
      corun.scenario = UnregulatedCoruns::scenario_of(p.scenario);
      added.push_back(std::move(corun));
      plan.measurements.push_back(measurements);
    }
    plan.measurements[it->second] = std::max(plan.measurements[it->second], measurements);
  }
  for (auto& p : added)
    loaded.points.push_back(std::move(p));
  return plan;
}

// The tasks of this shard in phases that run one after another (the tasks of one phase run in
// any order, --jobs at a time). A baseline measured once (sim: deterministic) comes before every
// point. A baseline measured R_b times (hw) is interleaved with the repetitions R of the points:
// measurement k runs just before repetition round baseline_round(k, R, R_b) (R_b >= R: one
// before each round, the extra ones before the first rounds), so that the machine's drift hits
// the baseline and the co-runs alike and every round has a baseline measured before it.
struct TaskPlan {
  std::vector<std::vector<Task>> phases;
  std::size_t tasks = 0;       // in all phases
  std::size_t runs = 0;        // point runs among them (the rest measure baselines, co-runs)
  std::size_t skipped = 0;     // runs of this shard already in points.csv
  std::set<std::string> keys;  // baselines this shard's points use
};

// Adjacent baselines (hw.adjacent_baselines): a round's phases run by run (`points`: co-runs
// and points, in order), each run's isolation measurements (its own baselines) right before it;
// measurements whose run is not in this round (a resumed folder holds it) first.
template <typename Add>
void add_adjacent(std::vector<Task> isolation, const std::vector<Task>& points, const Add& add) {
  std::map<std::size_t, std::vector<Task>> by_point;
  for (Task& t : isolation)
    by_point[t.point].push_back(std::move(t));
  std::vector<Task> orphans;
  for (auto& [point, tasks] : by_point)
    if (std::none_of(points.begin(), points.end(), [&](const Task& t) { return t.point == point; }))
      orphans.insert(orphans.end(), tasks.begin(), tasks.end());
  add(std::move(orphans));
  for (const Task& t : points) {
    if (const auto it = by_point.find(t.point); it != by_point.end()) add(std::move(it->second));
    add({t});
  }
}

bool in_shard(const LoadedPoint& p, const RunOptions& opt) {
  return p.sweep.index % static_cast<std::size_t>(opt.shard_count) ==
         static_cast<std::size_t>(opt.shard_index);
}

// The baselines a shard's runs need, by key in first-use order: which run (point) measures it,
// its workload and core, and how many measurements.
struct BaselineNeeds {
  struct Need {
    std::size_t point = 0;
    const WorkloadInfo* workload = nullptr;
    int core = 0;
    int measurements = 1;
    bool corun = false;  // a co-run's own baseline (hw.adjacent_baselines)
  };
  std::map<std::string, Need> by_key;
  std::vector<std::string> order;

  void add(const std::string& key, Need n) {
    auto [it, added] = by_key.try_emplace(key, n);
    if (added) order.push_back(key);
    it->second.measurements = std::max(it->second.measurements, n.measurements);
  }
};

// A shard's tasks by repetition round, before they are put into phases.
struct RoundTasks {
  std::vector<std::vector<Task>> isolation, coruns, points;
  bool interleave = false;  // more than one measurement of a baseline: rounds, not one pass
  bool adjacent = false;    // hw.adjacent_baselines: a run's baselines right before it
  explicit RoundTasks(int reps)
      : isolation(static_cast<std::size_t>(reps)),
        coruns(static_cast<std::size_t>(reps)),
        points(static_cast<std::size_t>(reps)) {}
};

// The shard's point runs a resumed folder lacks, by round, and the baselines they need.
void plan_point_runs(const LoadedScenario& loaded, const RunOptions& opt,
                     const ResultsStore::Opened& opened, const Backend& backend,
                     std::size_t point_count, RoundTasks& rounds, BaselineNeeds& needs,
                     std::size_t& skipped) {
  // Each point's baseline keys (RT nodes, then nRT nodes), on --jobs threads.
  std::vector<std::vector<std::string>> keys(point_count);
  parallel_for(point_count, worker_threads(opt), [&](std::size_t i) {
    const Scenario& s = loaded.points[i].scenario;
    for (const auto& n : s.nodes.rt)
      keys[i].push_back(Baselines::key(s, n.workload, n.core));
    for (const auto& n : s.nodes.nrt)
      keys[i].push_back(Baselines::key(s, n.workload, n.core));
  });
  for (std::size_t i = 0; i < point_count; ++i) {
    const LoadedPoint& p = loaded.points[i];
    if (!in_shard(p, opt)) continue;
    for (int rep = 0; rep < p.scenario.repetitions; ++rep) {
      if (opened.done.count({p.sweep.id, rep})) {
        ++skipped;
        continue;
      }
      rounds.points[static_cast<std::size_t>(rep)].push_back(
          {Task::Kind::Point, p.sweep.index, rep, "", nullptr, 0});
    }
    const int measurements = backend.baseline_repetitions(p.scenario);
    rounds.adjacent = rounds.adjacent || p.scenario.hw.adjacent_baselines;
    rounds.interleave = rounds.interleave || measurements > 1 || rounds.adjacent;
    std::size_t k = 0;
    for (const auto& n : p.scenario.nodes.rt)
      needs.add(keys[i][k++], {p.sweep.index, &n.workload, n.core, measurements});
    for (const auto& n : p.scenario.nodes.nrt)
      needs.add(keys[i][k++], {p.sweep.index, &n.workload, n.core, measurements});
  }
}

// The unregulated co-run measurements a resumed folder (or another shard) lacks, by round; with
// adjacent baselines a co-run has baselines of its own too, measured before each of its runs.
void plan_corun_runs(const LoadedScenario& loaded, const CorunPlan& corun_plan,
                     const UnregulatedCoruns& coruns_held, int reps, RoundTasks& rounds,
                     BaselineNeeds& needs) {
  for (std::size_t c = 0; c < corun_plan.measurements.size(); ++c) {
    const std::size_t point = corun_plan.first + c;
    const Scenario& s = loaded.points[point].scenario;
    const int measurements = corun_plan.measurements[c];
    const auto need = [&](const WorkloadInfo& w, int core) {
      needs.add(Baselines::key(s, w, core), {point, &w, core, measurements, true});
    };
    for (const auto& n : s.nodes.rt)
      if (rounds.adjacent) need(n.workload, n.core);
    for (const auto& n : s.nodes.nrt)
      if (rounds.adjacent) need(n.workload, n.core);
    for (int k = 0; k < measurements; ++k) {
      if (coruns_held.has(loaded.points[point].sweep.id, k)) continue;
      rounds.coruns[static_cast<std::size_t>(baseline_round(k, reps, measurements))].push_back(
          {Task::Kind::Point, point, k, "", nullptr, 0, true});
    }
  }
}

// The baseline measurements a resumed folder (or another shard) lacks, by round.
void plan_isolation_runs(const BaselineNeeds& needs, const ResultsStore::Opened& opened, int reps,
                         RoundTasks& rounds, std::set<std::string>& keys) {
  for (const std::string& key : needs.order) {
    const BaselineNeeds::Need& n = needs.by_key.at(key);
    keys.insert(key);
    const auto held = opened.baselines.all().find(key);
    for (int k = 0; k < n.measurements; ++k) {
      if (held != opened.baselines.all().end() && held->second.runs.count(k)) continue;
      const auto round = static_cast<std::size_t>(baseline_round(k, reps, n.measurements));
      rounds.isolation[round].push_back(
          {Task::Kind::Isolation, n.point, k, key, n.workload, n.core, n.corun});
    }
  }
}

// The rounds' tasks in phases: one pass (every baseline, then the co-runs, then the points in
// sweep order), or round by round (adjacent: run by run).
void phase_rounds(RoundTasks rounds, const CorunPlan& corun_plan, TaskPlan& plan) {
  const auto add = [&](std::vector<Task> phase) {
    plan.tasks += phase.size();
    for (const Task& t : phase)
      plan.runs += t.kind == Task::Kind::Point && !corun_plan.is_corun(t.point) ? 1 : 0;
    if (!phase.empty()) plan.phases.push_back(std::move(phase));
  };
  if (!rounds.interleave) {
    std::vector<Task> isolation, coruns, points;
    for (auto& r : rounds.isolation)
      isolation.insert(isolation.end(), r.begin(), r.end());
    for (auto& r : rounds.coruns)
      coruns.insert(coruns.end(), r.begin(), r.end());
    for (auto& r : rounds.points)
      points.insert(points.end(), r.begin(), r.end());
    std::stable_sort(points.begin(), points.end(),
                     [](const Task& a, const Task& b) { return a.point < b.point; });
    add(std::move(isolation));
    add(std::move(coruns));
    add(std::move(points));
    return;
  }
  for (std::size_t r = 0; r < rounds.isolation.size(); ++r) {
    if (rounds.adjacent) {
      std::vector<Task> runs = std::move(rounds.coruns[r]);
      runs.insert(runs.end(), rounds.points[r].begin(), rounds.points[r].end());
      add_adjacent(std::move(rounds.isolation[r]), runs, add);
      continue;
    }
    add(std::move(rounds.isolation[r]));
    add(std::move(rounds.coruns[r]));
    add(std::move(rounds.points[r]));
  }
}

TaskPlan plan_tasks(const LoadedScenario& loaded, const RunOptions& opt,
                    const ResultsStore::Opened& opened, const Backend& backend,
                    const CorunPlan& corun_plan, const UnregulatedCoruns& coruns_held) {
  TaskPlan plan;
  const int reps = loaded.points.front().scenario.repetitions;
  RoundTasks rounds(reps);
  BaselineNeeds needs;
  plan_point_runs(loaded, opt, opened, backend, corun_plan.first, rounds, needs, plan.skipped);
  plan_corun_runs(loaded, corun_plan, coruns_held, reps, rounds, needs);
  plan_isolation_runs(needs, opened, reps, rounds, plan.keys);
  phase_rounds(std::move(rounds), corun_plan, plan);
  return plan;
}

int worker_count(const RunOptions& opt, const Backend& backend) {
  const int jobs = requested_jobs(opt);
  if (backend.process_per_task() || jobs <= 1) return jobs;
  if (opt.jobs > 1)
    std::cerr << "note: the " << backend.name()
              << " backend measures one point at a time; --jobs ignored\n";
  return 1;
}

// Runs task lists through an executor until they are done, one fails, or a stop signal
// arrives; gathers what the manifest needs (fallbacks, facts) into `report`.
class TaskRunner {
 public:
  TaskRunner(const LoadedScenario& loaded, const CorunPlan& coruns, Executor& exec,
             Progress& progress, InvocationReport& report,
             std::set<std::pair<std::string, std::string>> fallbacks)
      : loaded_(loaded),
        coruns_(coruns),
        exec_(exec),
        progress_(progress),
        report_(report),
        fallbacks_seen_(std::move(fallbacks)) {}

  template <typename OnResult>
  void run(const std::vector<Task>& tasks, const OnResult& on_result) {
    std::size_t next = 0;
    while (true) {
      while (next < tasks.size() && exec_.can_submit() && failure_.empty() && !stop_signal()) {
        exec_.submit(next, tasks[next]);
        ++next;
      }
      if (stop_signal()) exec_.stop_all();
      if (!exec_.busy()) break;
      auto [id, r] = exec_.wait_one();
      const Task& t = tasks[id];
      const bool corun = t.kind == Task::Kind::Point && coruns_.is_corun(t.point);
      const auto label = [&] {
        return t.kind == Task::Kind::Isolation
                   ? "isolation " + t.iso_key + " #" + std::to_string(t.rep)
               : corun ? "unregulated co-run " + loaded_.points[t.point].sweep.id + " #" +
                             std::to_string(t.rep)
                       : point_label(loaded_.points[t.point].sweep, t.rep);
      };
      if (r.interrupted || (stop_signal() && !r.ok)) {
        interrupted_ = true;
        continue;
      }
      if (!r.ok) {
        if (failure_.empty()) failure_ = label() + ": " + r.error;
        continue;
      }
      absorb(r);
      on_result(t, r);
      if (t.kind == Task::Kind::Point && !corun) ++runs_done_;
      progress_.update(runs_done_, label);
    }
  }

  const std::string& failure() const { return failure_; }
  bool interrupted() const { return interrupted_ || stop_signal(); }

 private:
  void absorb(const TaskResult& r) {
    for (const auto& [what, detail] : r.fallbacks)
      if (fallbacks_seen_.emplace(what, detail).second) {
        progress_.finish();
        std::cerr << "warning: fallback (" << what << "): " << detail << "\n";
        report_.fallbacks.emplace_back(what, detail);
      }
    for (const auto& [k, v] : r.facts)
      report_.facts[k] = v;
  }

  const LoadedScenario& loaded_;
  const CorunPlan& coruns_;
  Executor& exec_;
  Progress& progress_;
  InvocationReport& report_;
  std::set<std::pair<std::string, std::string>> fallbacks_seen_;
  std::string failure_;
  bool interrupted_ = false;
  std::size_t runs_done_ = 0;  // point runs finished (progress counts runs, not baselines)
};

// Runs' samples and rows on their way to the results folder: written together (one lock, one
// write per file) once kRows wait or kDelay has passed since the last write, and when flushed.
// A run that comes kDelay or more after the last write is written at once (hw points, slow sim
// points); a killed run loses at most those waiting (complete rows only: --resume runs them
// again).
class RowWriter {
 public:
  RowWriter(const ResultsStore& store, InvocationReport& report) : store_(store), report_(report) {}
  ~RowWriter() {  // rows behind an exception are kept as well
    try {
      flush();
    } catch (const std::exception&) {  // the exception on its way is the one to report
    }
  }
  RowWriter(const RowWriter&) = delete;
  RowWriter& operator=(const RowWriter&) = delete;

  void add(const std::pair<std::string, std::string>& rows) {
    samples_ += rows.first;
    rows_ += rows.second;
    ++waiting_;
    if (waiting_ >= kRows || std::chrono::steady_clock::now() - written_ >= kDelay) flush();
  }
  std::size_t waiting() const { return waiting_; }
  void flush() {
    if (waiting_ == 0) return;
    store_.append_runs(samples_, rows_);
    written_ = std::chrono::steady_clock::now();
    report_.rows += waiting_;
    samples_.clear();
    rows_.clear();
    waiting_ = 0;
  }

 private:
  static constexpr std::size_t kRows = 256;
  static constexpr std::chrono::milliseconds kDelay{100};
  const ResultsStore& store_;
  InvocationReport& report_;
  std::string samples_, rows_;
  std::size_t waiting_ = 0;
  std::chrono::steady_clock::time_point written_ = std::chrono::steady_clock::now() - kDelay;
};

// The phases in order; after each phase of baselines (or co-runs) they are saved (for resumed
// runs and other shards); each point run's samples and row are appended (RowWriter) once it and
// every run before it in the phase have finished (the few that finish early wait, at most
// kHeldRuns of them: appended in order, the files need no rewrite when the run ends), with the
// baselines and co-runs measured so far (the rows are refreshed with all of them when the run
// finishes). Returns whether a baseline or co-run was measured after a row was written (so that
// a row may lack it).
// The points.csv row of a point run, as it is appended (the rows of adaptive rounds are judged
// from it).
using OnRow = std::function<void(const Task& task, const std::string& row)>;

// An nRT node that did none of its work in a run has no slowdown (an empty nrt_slowdown): said,
// with the likely cause where the node samples itself.
std::vector<std::string> idle_nrt_warnings(const PointOutcome& o, const LoadedPoint& p, int rep) {
  std::vector<std::string> out;
  const RegulationSpec& r = p.scenario.regulation;
  for (const auto& n : o.nrt) {
    if (n.runs > 0.0) continue;
    std::string w = "point " + p.sweep.id + " repetition " + std::to_string(rep) + ": nRT node '" +
                    n.name + "' did none of its work (nrt_runs 0), so its slowdown is not measured";
    if (r.sampling == Sampling::Self)
      w += "; it samples itself every " + std::to_string(r.sampling_period_us) +
           " us, which may leave it no time for its work (a longer sampling_period_us, or "
           "external sampling)";
    out.push_back(std::move(w));
  }
  return out;
}

bool run_tasks(const TaskPlan& plan, const CorunPlan& corun_plan, RunState& st,
               const ResultsStore& store, TaskRunner& runner, InvocationReport& report,
               json& trace_events, const OnRow& on_row = {}) {
  bool measured_after_rows = false;
  constexpr std::size_t kHeldRuns = 256;
  RowWriter writer(store, report);
  for (const auto& phase : plan.phases) {
    bool measured = false, corun_measured = false;
    std::map<std::size_t, std::pair<std::string, std::string>> held;  // by position in phase
    std::size_t next = 0;  // position of the next run to append
    std::vector<bool> done(phase.size(), false);
    const auto append = [&](const std::pair<std::string, std::string>& rows) { writer.add(rows); };
    const auto flush_ready = [&] {
      while (next < phase.size() && done[next]) {
        if (const auto it = held.find(next); it != held.end()) {
          append(it->second);
          held.erase(it);
        }
        ++next;
      }
    };
    runner.run(phase, [&](const Task& t, const TaskResult& r) {
      const auto position = static_cast<std::size_t>(&t - phase.data());
      done[position] = true;
      if (t.kind != Task::Kind::Point || corun_plan.is_corun(t.point))
        measured_after_rows = measured_after_rows || report.rows > 0 || writer.waiting() > 0;
      if (t.kind == Task::Kind::Isolation) {
        st.baselines.put(t.iso_key, r.iso, t.rep);
        measured = true;
      } else if (corun_plan.is_corun(t.point)) {
        CorunResult c;
        for (const auto& n : r.outcome.rt)
          c.rt_time_us.push_back(n.time_us);
        for (const auto& n : r.outcome.nrt)
          c.nrt_time_us.push_back(n.time_us);
        st.coruns.put(st.loaded->points[t.point].sweep.id, std::move(c), t.rep);
        corun_measured = true;
      } else {
        const LoadedPoint& lp = st.loaded->points[t.point];
        for (const auto& w : idle_nrt_warnings(r.outcome, lp, t.rep)) {
          std::cerr << "warning: " << w << "\n";
          report.warnings.push_back(w);
        }
        auto rows = run_rows(r, lp, t.rep, st);
        if (on_row) on_row(t, rows.second);
        held.emplace(position, std::move(rows));
        for (const auto& e : r.trace)
          trace_events.push_back(e);
      }
      flush_ready();
      if (held.size() > kHeldRuns) {  // a slow run holds back too many: append them now
        for (const auto& [pos, rows] : held)
          append(rows);
        held.clear();
      }
    });
    for (const auto& [pos, rows] : held)  // behind a failed or stopped run: kept all the same
      append(rows);
    writer.flush();
    if (measured) store.save_baselines(st.baselines);
    if (corun_measured) st.coruns.save(store.dir());
    if (!runner.failure().empty() || stop_signal()) return measured_after_rows;
  }
  return measured_after_rows;
}

// Tells the user, once per baseline of this shard, when its measurements spread too much.
void warn_noisy_baselines(const TaskPlan& plan, const Baselines& baselines) {
  for (const std::string& key : plan.keys) {
    const auto it = baselines.all().find(key);
    if (it == baselines.all().end()) continue;
    if (const std::string w = it->second.noise_warning(key); !w.empty())
      std::cerr << "warning: " << w << "\n";
  }
}

// ---------------------------------------------------------------------------------------------
// Repetitions and their precision (model/results/precision.h, docs/design.md section 5).

// How many rounds a point runs on this backend: hw.precision_pct / max_repetitions on a backend
// that judges precision (hw), else the scenario's repetitions.
PrecisionRule rule_of(const Scenario& s, const Backend& backend) {
  if (!backend.judges_precision()) return precision_rule(s.repetitions, std::nullopt, 0);
  return precision_rule(s.repetitions, s.hw.precision_pct, s.hw.max_repetitions);
}

bool adaptive_rounds(const Scenario& s, const Backend& backend) {
  return backend.judges_precision() && s.hw.precision_pct.has_value();
}

bool adaptive_run(const LoadedScenario& loaded, const Backend& backend) {
  return std::any_of(loaded.points.begin(), loaded.points.end(),
                     [&](const LoadedPoint& p) { return adaptive_rounds(p.scenario, backend); });
}

RoundPairing pairing_of(const Scenario& s, const Backend& backend) {
  RoundPairing r;
  r.repetitions = s.repetitions;
  r.measurements = backend.baseline_repetitions(s);
  r.one_per_round = adaptive_rounds(s, backend) || s.hw.adjacent_baselines;
  return r;
}

// Co-run times of a shard's point runs (RT nodes, then nRT nodes), by point index and rep.
using RunTimes = std::map<std::size_t, std::map<int, std::vector<double>>>;

// The rows points.csv already holds for this shard's points (a resumed run).
void read_run_times(const fs::path& points_csv, const LoadedScenario& loaded,
                    std::size_t point_count, const RunOptions& opt, RunTimes& out) {
  std::error_code ec;
  if (!fs::exists(points_csv, ec)) return;
  std::map<std::string, std::size_t> index_of;
  for (std::size_t i = 0; i < point_count; ++i)
    if (in_shard(loaded.points[i], opt)) index_of.emplace(loaded.points[i].sweep.id, i);
  const std::vector<std::string> header = header_of(loaded);
  const auto lines = split_lines(read_file(points_csv));
  for (std::size_t l = 1; l < lines.size(); ++l) {
    const auto cells = csv_split(lines[l]);
    if (cells.size() != header.size()) continue;
    const auto it = index_of.find(cells[0]);
    if (it == index_of.end()) continue;
    char* end = nullptr;
    const long rep = std::strtol(cells[1].c_str(), &end, 10);
    if (*end != '\0' || rep < 0) continue;
    out[it->second][static_cast<int>(rep)] =
        row_node_times(header, cells, loaded.points[it->second].scenario);
  }
}

// The CIs of a point's slowdowns (RT nodes, then nRT nodes) over its first `rounds` runs (all
// with -1).
std::vector<MeanCi> point_cis(const Scenario& s, const Backend& backend, const Baselines& b,
                              const std::map<int, std::vector<double>>& times, int rounds = -1) {
  std::vector<const BaselineRuns*> runs;
  const auto add = [&](const WorkloadInfo& w, int core) {
    const auto it = b.all().find(Baselines::key(s, w, core));
    runs.push_back(it == b.all().end() ? nullptr : &it->second);
  };
  for (const auto& n : s.nodes.rt)
    add(n.workload, n.core);
  for (const auto& n : s.nodes.nrt)
    add(n.workload, n.core);
  std::map<int, std::vector<double>> first;
  for (const auto& [rep, t] : times)
    if (rounds < 0 || rep < rounds) first.emplace(rep, t);
  return slowdown_cis(runs, first, pairing_of(s, backend));
}

std::string ci_column(const Scenario& s, std::size_t node) {
  const std::size_t rt = s.nodes.rt.size();
  const std::string kind = node < rt ? "rt" : "nrt";
  const std::size_t i = node < rt ? node : node - rt;
  return (i == 0 ? kind + "_" : kind + std::to_string(i) + "_") + "slowdown_ci95_pct";
}

std::string pct_text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f %%", v);
  return buf;
}

// A point of this shard in the adaptive rounds: its stopping rule, its baselines (RT nodes, then
// nRT nodes) and its co-run point.
struct AdaptivePoint {
  struct Node {
    std::string key;
    const WorkloadInfo* workload;
    int core;
  };
  std::size_t point;
  PrecisionRule rule;
  std::vector<Node> nodes;
  std::optional<std::size_t> corun;  // index of its co-run point
};

std::vector<AdaptivePoint> adaptive_points(const LoadedScenario& loaded, const RunOptions& opt,
                                           const Backend& backend, const CorunPlan& corun_plan,
                                           std::set<std::string>& keys) {
  std::map<std::string, std::size_t> corun_index;
  for (std::size_t c = corun_plan.first; c < loaded.points.size(); ++c)
    corun_index.emplace(loaded.points[c].sweep.id, c);
  std::vector<AdaptivePoint> shard;
  for (std::size_t i = 0; i < corun_plan.first; ++i) {
    const LoadedPoint& p = loaded.points[i];
    if (!in_shard(p, opt)) continue;
    AdaptivePoint e{i, rule_of(p.scenario, backend), {}, std::nullopt};
    for (const auto& n : p.scenario.nodes.rt)
      e.nodes.push_back({Baselines::key(p.scenario, n.workload, n.core), &n.workload, n.core});
    for (const auto& n : p.scenario.nodes.nrt)
      e.nodes.push_back({Baselines::key(p.scenario, n.workload, n.core), &n.workload, n.core});
    for (const auto& n : e.nodes)
      keys.insert(n.key);
    if (const auto k = corun_plan.key_of.find(p.sweep.id); k != corun_plan.key_of.end())
      if (const auto c = corun_index.find(k->second); c != corun_index.end()) e.corun = c->second;
    shard.push_back(std::move(e));
  }
  return shard;
}

// What adaptive round r measures: the isolation measurements, co-runs and point runs a resumed
// folder lacks, for the points still short of their precision.
struct AdaptiveRound {
  std::vector<Task> isolation, coruns, points;
  std::size_t extra = 0;   // runs beyond the planned minimum
  std::size_t active = 0;  // points in this round
  std::set<std::string> iso_added, corun_added;

  void isolation_once(const std::string& key, Task t) {
    if (iso_added.insert(key).second) isolation.push_back(std::move(t));
  }
};

AdaptiveRound adaptive_round(const LoadedScenario& loaded, const ResultsStore::Opened& opened,
                             const Backend& backend, const CorunPlan& corun_plan,
                             const RunState& st, const RunTimes& times,
                             const std::vector<AdaptivePoint>& shard, bool adjacent, int r,
                             std::set<std::string>& keys) {
  AdaptiveRound round;
  const auto held = [&](const std::string& key) {
    const auto it = st.baselines.all().find(key);
    return it != st.baselines.all().end() && it->second.runs.count(r) > 0;
  };
  // Adjacent baselines: the co-run's own, measurement r, unless the folder holds it.
  const auto corun_baselines = [&](std::size_t point) {
    const Scenario& c = loaded.points[point].scenario;
    const auto add = [&](const WorkloadInfo& w, int core) {
      const std::string key = Baselines::key(c, w, core);
      keys.insert(key);
      if (!held(key))
        round.isolation_once(key, {Task::Kind::Isolation, point, r, key, &w, core, true});
    };
    for (const auto& n : c.nodes.rt)
      add(n.workload, n.core);
    for (const auto& n : c.nodes.nrt)
      add(n.workload, n.core);
  };
  for (const AdaptivePoint& e : shard) {
    const LoadedPoint& p = loaded.points[e.point];
    if (r >= e.rule.max_rounds) continue;
    const bool done = opened.done.count({p.sweep.id, r}) > 0;
    if (r >= e.rule.min_rounds) {
      const auto it = times.find(e.point);
      const auto verdict = judge_rounds(
          e.rule, r,
          point_cis(p.scenario, backend, st.baselines,
                    it == times.end() ? std::map<int, std::vector<double>>{} : it->second, r));
      if (verdict != RoundsVerdict::More) continue;
      if (!done) ++round.extra;
    }
    ++round.active;
    if (!done) round.points.push_back({Task::Kind::Point, e.point, r, "", nullptr, 0});
    for (const AdaptivePoint::Node& n : e.nodes)
      if (!held(n.key))
        round.isolation_once(n.key, {Task::Kind::Isolation, e.point, r, n.key, n.workload, n.core});
    if (!e.corun) continue;
    const std::size_t c = *e.corun - corun_plan.first;
    const std::string& id = loaded.points[*e.corun].sweep.id;
    if (r < corun_plan.measurements[c] && !st.coruns.has(id, r) &&
        round.corun_added.insert(id).second) {
      round.coruns.push_back({Task::Kind::Point, *e.corun, r, "", nullptr, 0, true});
      if (adjacent) corun_baselines(*e.corun);
    }
  }
  return round;
}

// The adaptive rounds (hw.precision_pct): round r measures, for every point still short of its
// precision (and below its cap), measurement r of each of its baselines, then (in the first
// rounds) its unregulated co-run, then its repetition r (adjacent baselines: run by run); the
// points that reached their target after r rounds (or their cap) are left out of round r. What a
// resumed folder already holds is not measured again. Returns whether a baseline or co-run was
// measured after a row was written.
bool run_adaptive(const LoadedScenario& loaded, const RunOptions& opt,
                  const ResultsStore::Opened& opened, const Backend& backend,
                  const CorunPlan& corun_plan, RunState& st, const ResultsStore& store,
                  TaskRunner& runner, InvocationReport& report, json& trace_events,
                  Progress& progress, RunTimes& times, std::set<std::string>& keys) {
  const std::vector<AdaptivePoint> shard = adaptive_points(loaded, opt, backend, corun_plan, keys);
  int max_rounds = 0;
  for (const AdaptivePoint& e : shard)
    max_rounds = std::max(max_rounds, e.rule.max_rounds);
  const bool adjacent = std::any_of(shard.begin(), shard.end(), [&](const AdaptivePoint& e) {
    return loaded.points[e.point].scenario.hw.adjacent_baselines;
  });
  bool measured_after_rows = false;
  for (int r = 0; r < max_rounds; ++r) {
    AdaptiveRound next =
        adaptive_round(loaded, opened, backend, corun_plan, st, times, shard, adjacent, r, keys);
    if (next.active == 0) break;
    // A resumed folder may hold the whole round already.
    if (next.points.empty() && next.isolation.empty() && next.coruns.empty()) continue;
    progress.set_total(progress.total() + next.extra);
    TaskPlan round;
    const auto add = [&round](std::vector<Task> phase) {
      round.tasks += phase.size();
      if (!phase.empty()) round.phases.push_back(std::move(phase));
    };
    if (adjacent) {
      next.coruns.insert(next.coruns.end(), next.points.begin(), next.points.end());
      add_adjacent(std::move(next.isolation), next.coruns, add);
    } else {
      add(std::move(next.isolation));
      add(std::move(next.coruns));
      add(std::move(next.points));
    }
    measured_after_rows =
        run_tasks(round, corun_plan, st, store, runner, report, trace_events,
                  [&](const Task& t, const std::string& row) {
                    std::string line = row;
                    if (!line.empty() && line.back() == '\n') line.pop_back();
                    times[t.point][t.rep] =
                        row_node_times(st.header, csv_split(line), loaded.points[t.point].scenario);
                  }) ||
        measured_after_rows;
    if (!runner.failure().empty() || stop_signal()) break;
  }
  return measured_after_rows;
}

// What the run reached, per point of this shard: its rounds, each slowdown's CI, and why it
// stopped; for the manifest (`precision`) and the summary line.
struct PrecisionReport {
  json manifest;
  std::string repetitions;  // "3" or "3-20 (median 4)"
  std::string summary;      // "" when nothing to say (one repetition, a deterministic backend)
};

PrecisionReport report_precision(const LoadedScenario& loaded, const RunOptions& opt,
                                 std::size_t point_count, const Backend& backend,
                                 const Baselines& baselines, const RunTimes& times, bool finished) {
  PrecisionReport out;
  const Scenario& first = loaded.points.front().scenario;
  const bool adaptive = adaptive_run(loaded, backend);
  const PrecisionRule first_rule = rule_of(first, backend);
  json points = json::object();
  std::vector<double> reps, widest;
  std::size_t judged = 0, precise = 0, capped = 0, open = 0;
  for (std::size_t i = 0; i < point_count; ++i) {
    const LoadedPoint& p = loaded.points[i];
    if (!in_shard(p, opt)) continue;
    const auto it = times.find(i);
    if (it == times.end()) continue;
    const auto& t = it->second;
    const std::vector<MeanCi> cis = point_cis(p.scenario, backend, baselines, t);
    const PrecisionRule rule = rule_of(p.scenario, backend);
    RoundsVerdict verdict = judge_rounds(rule, static_cast<int>(t.size()), cis);
    json entry{{"repetitions", t.size()}};
    for (std::size_t n = 0; n < cis.size(); ++n)
      entry[ci_column(p.scenario, n)] = cis[n].half_width_pct();
    if (rule.target_pct) entry["target_pct"] = *rule.target_pct;
    entry["verdict"] = verdict == RoundsVerdict::More ? (finished ? "more wanted" : "incomplete")
                                                      : std::string(to_string(verdict));
    points[p.sweep.id] = entry;
    reps.push_back(static_cast<double>(t.size()));
    const double w = widest_ci_pct(cis);
    if (std::isfinite(w)) widest.push_back(w);
    ++judged;
    precise += verdict == RoundsVerdict::Precise;
    capped += verdict == RoundsVerdict::Capped;
    open += verdict == RoundsVerdict::More;
  }
  if (judged == 0) return out;
  const auto [lo, hi] = std::minmax_element(reps.begin(), reps.end());
  out.repetitions = *lo == *hi ? std::to_string(static_cast<int>(*lo))
                               : std::to_string(static_cast<int>(*lo)) + "-" +
                                     std::to_string(static_cast<int>(*hi)) + " (median " +
                                     std::to_string(static_cast<int>(median(reps))) + ")";
  if (widest.empty()) {
    out.summary = "slowdown 95 % CI: not computable (fewer than two repetitions of a slowdown)";
  } else if (adaptive && first_rule.target_pct) {
    char target[32];
    std::snprintf(target, sizeof target, "%g %%", *first_rule.target_pct);
    out.summary = "slowdown 95 % CI within " + std::string(target) + " on " +
                  std::to_string(precise) + " of " + std::to_string(judged) + " point(s) (widest " +
                  pct_text(*std::max_element(widest.begin(), widest.end())) + ", median " +
                  pct_text(median(widest)) + ")";
    if (capped) out.summary += ", " + std::to_string(capped) + " stopped at the cap";
    if (open) out.summary += ", " + std::to_string(open) + " not finished";
  } else {
    out.summary = "slowdown 95 % CI: widest " +
                  pct_text(*std::max_element(widest.begin(), widest.end())) + ", median " +
                  pct_text(median(widest)) + " (set hw.precision_pct to repeat until a target)";
  }
  out.manifest = {
      {"method",
       "95 % confidence interval (Student t) of the mean of each slowdown over the point's "
       "repetitions, each repetition's co-run time over the baseline measured before the same "
       "round; half-width in percent of the mean"},
      {"target_pct", first_rule.target_pct ? json(*first_rule.target_pct) : json(nullptr)},
      {"min_repetitions", first_rule.min_rounds},
      {"max_repetitions", first_rule.max_rounds},
      {"summary", out.summary},
      {"points", points}};
  return out;
}

// Each point's rows with their slowdown CI cells from all of them (fill_ci_cells), for a
// backend that judges precision.
PointRefresher point_refresher(const LoadedScenario& loaded, const Backend& backend) {
  if (!backend.judges_precision()) return {};
  std::map<std::string, std::pair<const Scenario*, RoundPairing>> by_id;
  for (const auto& p : loaded.points)
    by_id.emplace(p.sweep.id, std::make_pair(&p.scenario, pairing_of(p.scenario, backend)));
  return [by_id, header = header_of(loaded)](
             const std::string& id, const std::vector<std::string>& lines, const Baselines& b) {
    const auto it = by_id.find(id);
    if (it == by_id.end()) return lines;
    return fill_ci_cells(header, lines, *it->second.first, b, it->second.second);
  };
}

// Brings a row's baseline and unregulated co-run cells up to date from the folder's baselines
// and co-runs (DIR/unregulated.json as it is now: read here, not under the store's lock). The
// co-run keys of this shard's points are `corun_plan`'s; another shard's are made here.
RowRefresher row_refresher(const LoadedScenario& loaded, const CorunPlan& corun_plan,
                           const std::filesystem::path& dir) {
  std::map<std::string, const LoadedPoint*> by_id;
  for (const auto& p : loaded.points)
    by_id.emplace(p.sweep.id, &p);
  return [by_id, keys = corun_plan.key_of, header = header_of(loaded),
          coruns = UnregulatedCoruns::read(dir)](
             const std::string& id, const std::string& line,
             const Baselines& b) mutable -> std::optional<std::string> {
    const auto it = by_id.find(id);
    if (it == by_id.end()) return std::nullopt;
    const Scenario& s = it->second->scenario;
    const auto fresh = refresh_isolation_cells(header, line, s, b);
    const std::string current = fresh.value_or(line);
    auto key = keys.find(id);
    if (key == keys.end() && UnregulatedCoruns::needed(s))
      key = keys.emplace(id, UnregulatedCoruns::key(s)).first;
    std::string filled =
        fill_unregulated_cells(header, current, s, key == keys.end() ? "" : key->second, coruns, b);
    if (!fresh && filled == line) return std::nullopt;
    return filled;
  };
}

int report_to_user(const RunOptions& opt, const InvocationReport& report, const fs::path& out,
                   std::size_t points, const PrecisionReport& precision, int reps) {
  if (report.status == "failed") {
    std::cerr << "error: " << report.error << "\n"
              << "rosguard: " << report.rows << " run(s) written to " << out.string()
              << " before the failure; complete rows are kept\n";
    return 1;
  }
  if (report.status == "interrupted") {
    std::cerr << "rosguard: interrupted; " << report.rows << " complete run(s) kept in "
              << out.string() << " (continue with --resume)\n";
    return stop_signal() == SIGTERM ? 143 : 130;
  }
  if (!opt.quiet) {
    char elapsed[32];
    std::snprintf(elapsed, sizeof elapsed, "%.2f s", report.elapsed_s);
    std::cout << "rosguard: " << report.rows << " run(s) of " << points << " point(s) x "
              << (precision.repetitions.empty() ? std::to_string(reps) : precision.repetitions)
              << " repetition(s) written to " << out.string() << " in " << elapsed
              << (precision.summary.empty() ? "" : "; " + precision.summary) << "\n";
  }
  return 0;
}

// Point id -> sweep index: the canonical row order of points.csv.
std::map<std::string, std::size_t> point_order(const LoadedScenario& loaded) {
  std::map<std::string, std::size_t> order;
  for (const auto& p : loaded.points)
    order.emplace(p.sweep.id, p.sweep.index);
  return order;
}

// How this invocation ended: failed (with the first error), interrupted or complete.
void close_report(InvocationReport& report, const TaskRunner& runner, const Progress& progress) {
  report.error = runner.failure();
  report.status = !report.error.empty()  ? "failed"
                  : runner.interrupted() ? "interrupted"
                                         : "complete";
  report.elapsed_s = progress.seconds();
}

// The rows every point has when the folder is complete: its repetitions, or with adaptive
// rounds (hw.precision_pct) the least min_rounds of the points' rules.
int rows_per_point(const LoadedScenario& loaded, const Backend& backend, bool adaptive) {
  const Scenario& first = loaded.points.front().scenario;
  if (!adaptive) return first.repetitions;
  int min_rounds = rule_of(first, backend).min_rounds;
  for (const auto& p : loaded.points)
    min_rounds = std::min(min_rounds, rule_of(p.scenario, backend).min_rounds);
  return min_rounds;
}

// The backend's setup for the whole run (hw: its own threads off the measured cores, the
// measured CPUs timed): its warnings, new fallbacks, facts and manifest entries into the report.
void prepare_backend_run(const LoadedScenario& loaded, const RunOptions& opt, Backend& backend,
                         const ResultsStore::Opened& opened, InvocationReport& report) {
  std::vector<const Scenario*> shard_points;
  for (const auto& p : loaded.points)
    if (in_shard(p, opt)) shard_points.push_back(&p.scenario);
  RunSetup setup = backend.prepare_run(shard_points);
  for (const auto& w : setup.warnings)
    std::cerr << "warning: " << w << "\n";
  for (const auto& [what, detail] : setup.fallbacks)
    if (!opened.fallbacks.count({what, detail})) {
      std::cerr << "warning: fallback (" << what << "): " << detail << "\n";
      report.fallbacks.emplace_back(what, detail);
    }
  report.facts.insert(setup.facts.begin(), setup.facts.end());
  report.warnings = std::move(setup.warnings);
  report.manifest = std::move(setup.manifest);
}

// The manifest's unregulated_corun fact: whether and where the co-run is measured.
std::string unregulated_corun_fact(const LoadedScenario& loaded, const RunOptions& opt) {
  const bool elsewhere = std::any_of(
      loaded.points.begin(), loaded.points.end(),
      [](const LoadedPoint& p) { return UnregulatedCoruns::signalled_elsewhere(p.scenario); });
  return !opt.unregulated ? "off (rosguard run --no-unregulated)"
         : elsewhere      ? "not measured where an RT node is signalled by a topic (another "
                            "program's jobs cannot run twice); elsewhere once per co-run "
                            "(unregulated.json)"
                          : "measured once per co-run of the nodes with policy none "
                            "(unregulated.json)";
}

// Adaptive: the runs every point of this shard makes at least, and those of them the folder
// already holds.
std::pair<std::size_t, std::size_t> adaptive_minimum_runs(const LoadedScenario& loaded,
                                                          const RunOptions& opt,
                                                          const Backend& backend,
                                                          const ResultsStore::Opened& opened,
                                                          std::size_t scenario_points) {
  std::size_t planned = 0, skipped = 0;
  for (std::size_t i = 0; i < scenario_points; ++i) {
    const LoadedPoint& p = loaded.points[i];
    if (!in_shard(p, opt)) continue;
    for (int r = 0; r < rule_of(p.scenario, backend).min_rounds; ++r)
      opened.done.count({p.sweep.id, r}) ? ++skipped : ++planned;
  }
  return {planned, skipped};
}

// The executor of the run's tasks: worker processes on the task hosts, or in-process.
std::unique_ptr<Executor> start_executor(const RunState& st, const RunOptions& opt,
                                         const std::vector<std::unique_ptr<TaskHost>>& hosts) {
  std::vector<TaskHost*> host_ptrs;
  for (const auto& h : hosts)
    host_ptrs.push_back(h.get());
  return make_executor(st, st.backend->process_per_task(), worker_count(opt, *st.backend),
                       host_ptrs);
}

// The fallbacks the manifest already has and this invocation reported: each is warned once.
std::set<std::pair<std::string, std::string>> fallbacks_seen(const ResultsStore::Opened& opened,
                                                             const InvocationReport& report) {
  std::set<std::pair<std::string, std::string>> seen = opened.fallbacks;
  for (const auto& f : report.fallbacks)
    seen.insert(f);
  return seen;
}

// Records each written row's node times into `times`, for the precision of the slowdowns.
OnRow time_recorder(RunTimes& times, const RunState& st) {
  return [&times, &st](const Task& t, const std::string& row) {
    std::string line = row;
    if (!line.empty() && line.back() == '\n') line.pop_back();
    times[t.point][t.rep] =
        row_node_times(st.header, csv_split(line), st.loaded->points[t.point].scenario);
  };
}

// A run that threw still closes its manifest (status failed); the first error is the one
// reported, but a manifest that could not be updated is said, as `rosguard status` cannot.
void finish_after_error(ResultsStore& store, const InvocationReport& report,
                        const LoadedScenario& loaded, const CorunPlan& corun_plan,
                        const Backend& backend) {
  try {
    store.finish(report, row_refresher(loaded, corun_plan, store.dir()),
                 point_refresher(loaded, backend));
  } catch (const ManifestNotUpdatedError& m) {
    std::cerr << "error: " << m.what() << "\n";
  } catch (const std::exception&) {
  }
}

}  // namespace

LoadedScenario load_for_run(const RunOptions& opt, Loader& loader,
                            const BackendRegistry& backends) {
  LoadedScenario loaded = loader.load(opt.scenario_file, opt.backend);
  make_backend(loaded, backends);
  return loaded;
}

fs::path results_folder(const RunOptions& opt, const LoadedScenario& loaded) {
  return opt.out.empty() ? fs::path("results") / loaded.points.front().scenario.name : opt.out;
}

int run_scenario(const RunOptions& opt, Loader& loader, const BackendRegistry& backends) {
  // 1. Load and validate everything; errors here are InputErrors and nothing is written. The
  // task host (process-per-task backends) is forked before the points are built: it stays small.
  LoadedScenario loaded = loader.load_base(opt.scenario_file, opt.backend);
  const std::vector<std::unique_ptr<TaskHost>> hosts =
      start_task_hosts(loader, loaded, backends, opt.trace, requested_jobs(opt));
  loader.load_points(loaded, PointSelection::All, worker_threads(opt));
  std::unique_ptr<Backend> backend = make_backend(loaded, backends, worker_threads(opt));
  loader.print_warnings(loaded);  // on the console as `check` prints them; and in the manifest
  const Scenario& first = loaded.points.front().scenario;
  const bool adaptive = adaptive_run(loaded, *backend);

  // 2. The results folder: new, resumed, or shared with other shards of the same scenario.
  ResultsStore store(results_folder(opt, loaded), join(header_of(loaded), ","), point_order(loaded),
                     rows_per_point(loaded, *backend, adaptive), adaptive);
  const std::string shard = std::to_string(opt.shard_index) + "/" + std::to_string(opt.shard_count);
  store.claim_shard(shard);  // one writer per shard: a second one would write its runs twice
  store.prepare(opt.overwrite, opt.resume || opt.shard_count > 1, scenario_hash(loaded));
  std::error_code ec;
  if (opt.overwrite) fs::remove(store.dir() / "unregulated.json", ec);
  const ResultsStore::Opened opened =
      store.open(describe_run(loaded, first.backend, opt.command_line, worker_threads(opt)), shard);
  const int repetitions = first.repetitions;
  const std::size_t point_count = loaded.points.size();

  // 3. Tasks of this shard; 4. run them; 5. sort the rows (so --jobs and shards do not change
  // the bytes) and finish the manifest, also when something throws.
  InvocationReport report;
  CorunPlan corun_plan;
  PrecisionReport precision;
  // Rows another invocation or shard wrote, or rows written before a measurement they use, are
  // brought up to date when the run finishes; a fresh single-shard run that measured every
  // baseline and co-run before its first row has none (the refresh reads every row: 0.3 s for
  // 10,000 points).
  bool refresh_rows = true;
  try {
    // The backend's setup for the whole run (hw: its own threads off the measured cores, the
    // measured CPUs timed).
    if (!backend->process_per_task()) prepare_backend_run(loaded, opt, *backend, opened, report);
    // The co-run points are appended: `first` and other references into the points are stale.
    const Backend& be = *backend;
    corun_plan = add_corun_points(loaded, opt, [&](const Scenario& s) {
      return adaptive_rounds(s, be) ? rule_of(s, be).min_rounds : be.baseline_repetitions(s);
    });
    const std::size_t scenario_points = corun_plan.first;
    UnregulatedCoruns coruns = UnregulatedCoruns::read(store.dir());
    const TaskPlan plan =
        adaptive ? TaskPlan{} : plan_tasks(loaded, opt, opened, *backend, corun_plan, coruns);
    report.facts["unregulated_corun"] = unregulated_corun_fact(loaded, opt);
    // Adaptive: the runs every point makes at least, without those the folder holds.
    std::size_t planned_runs = plan.runs, skipped = plan.skipped;
    if (adaptive)
      std::tie(planned_runs, skipped) =
          adaptive_minimum_runs(loaded, opt, *backend, opened, scenario_points);
    report.skipped_on_resume = skipped;
    if (skipped > 0 && !opt.quiet)
      std::cerr << "resume: " << skipped << " run(s) already in " << store.points_path().string()
                << ", skipped\n";
    RunState st{&loaded,   backend.get(),     opened.baselines,
                opt.trace, header_of(loaded), std::move(coruns)};
    auto exec = start_executor(st, opt, hosts);
    StopSignalGuard signals;
    Progress progress(planned_runs, !opt.quiet);
    TaskRunner runner(loaded, corun_plan, *exec, progress, report, fallbacks_seen(opened, report));
    json trace_events = json::array();
    // The co-run times of this shard's runs, for the precision of the slowdowns.
    RunTimes times;
    if (backend->judges_precision() && !opened.done.empty())
      read_run_times(store.points_path(), loaded, scenario_points, opt, times);
    const OnRow record = time_recorder(times, st);
    std::set<std::string> keys = plan.keys;
    const bool measured_after_rows =
        adaptive ? run_adaptive(loaded, opt, opened, *backend, corun_plan, st, store, runner,
                                report, trace_events, progress, times, keys)
                 : run_tasks(plan, corun_plan, st, store, runner, report, trace_events,
                             backend->judges_precision() ? record : OnRow{});
    refresh_rows = measured_after_rows || opt.shard_count > 1 || !opened.done.empty();
    progress.finish();
    TaskPlan noisy;
    noisy.keys = keys;
    warn_noisy_baselines(noisy, st.baselines);
    if (backend->judges_precision()) {
      precision = report_precision(loaded, opt, scenario_points, *backend, st.baselines, times,
                                   runner.failure().empty() && !runner.interrupted());
      if (!precision.manifest.is_null()) report.manifest["precision"] = precision.manifest;
    }
    if (opt.trace && !trace_events.empty()) store.add_trace(trace_events);
    close_report(report, runner, progress);
  } catch (const std::exception& e) {
    report.status = "failed";
    report.error = e.what();
    finish_after_error(store, report, loaded, corun_plan, *backend);
    throw;
  }
  store.finish(report,
               refresh_rows ? row_refresher(loaded, corun_plan, store.dir()) : RowRefresher{},
               point_refresher(loaded, *backend));
  const int code = report_to_user(opt, report, store.dir(), point_count, precision, repetitions);
  if (opt.process_ends) new LoadedScenario(std::move(loaded));  // freed by the process's end
  return code;
}

}  // namespace rosguard

#include "runner.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <map>
#include <optional>
#include <set>

#include "core/error.h"
#include "progress.h"
#include "results/results.h"
#include "results_store.h"
#include "run_manifest.h"
#include "stop_signal.h"
#include "task_pool.h"
#include "unregulated.h"

namespace rosguard {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

std::unique_ptr<Backend> make_backend(const LoadedScenario& loaded,
                                      const BackendRegistry& backends) {
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
  // The loader's warnings (e.g. a controller sharing a core) go to the manifest; the backend
  // says what they mean for this run (as a fallback), so they are not printed twice.
  for (const auto& p : loaded.points)
    backend->validate(p.scenario);
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

// Appends one point per distinct co-run key this shard's regulated points need (none with
// `opt.unregulated` off).
CorunPlan add_corun_points(LoadedScenario& loaded, const RunOptions& opt, const Backend& backend) {
  CorunPlan plan;
  plan.first = loaded.points.size();
  if (!opt.unregulated) return plan;
  std::map<std::string, std::size_t> index;  // key -> its co-run point
  std::vector<LoadedPoint> added;
  for (std::size_t i = 0; i < plan.first; ++i) {
    const LoadedPoint& p = loaded.points[i];
    if (p.sweep.index % static_cast<std::size_t>(opt.shard_count) !=
            static_cast<std::size_t>(opt.shard_index) ||
        !UnregulatedCoruns::needed(p.scenario))
      continue;
    const std::string& key = plan.key_of[p.sweep.id] = UnregulatedCoruns::key(p.scenario);
    const int measurements = backend.baseline_repetitions(p.scenario);
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

TaskPlan plan_tasks(const LoadedScenario& loaded, const RunOptions& opt,
                    const ResultsStore::Opened& opened, const Backend& backend,
                    const CorunPlan& corun_plan, const UnregulatedCoruns& coruns_held) {
  TaskPlan plan;
  const int reps = loaded.points.front().scenario.repetitions;
  std::vector<std::vector<Task>> iso_rounds(static_cast<std::size_t>(reps)),
      corun_rounds(static_cast<std::size_t>(reps)), point_rounds(static_cast<std::size_t>(reps));
  struct Need {
    std::size_t point = 0;
    const WorkloadInfo* workload = nullptr;
    int core = 0;
    int measurements = 1;
  };
  std::map<std::string, Need> needs;  // by baseline key, in first-use order below
  std::vector<std::string> key_order;
  bool interleave = false;
  for (std::size_t i = 0; i < corun_plan.first; ++i) {
    const LoadedPoint& p = loaded.points[i];
    if (p.sweep.index % static_cast<std::size_t>(opt.shard_count) !=
        static_cast<std::size_t>(opt.shard_index))
      continue;
    for (int rep = 0; rep < p.scenario.repetitions; ++rep) {
      if (opened.done.count({p.sweep.id, rep})) {
        ++plan.skipped;
        continue;
      }
      point_rounds[static_cast<std::size_t>(rep)].push_back(
          {Task::Kind::Point, p.sweep.index, rep, "", nullptr, 0});
    }
    const int measurements = backend.baseline_repetitions(p.scenario);
    interleave = interleave || measurements > 1;
    const auto need = [&](const WorkloadInfo& w, int core) {
      const std::string key = Baselines::key(p.scenario, w, core);
      auto [it, added] = needs.try_emplace(key, Need{p.sweep.index, &w, core, 1});
      if (added) key_order.push_back(key);
      it->second.measurements = std::max(it->second.measurements, measurements);
    };
    for (const auto& n : p.scenario.nodes.rt)
      need(n.workload, n.core);
    for (const auto& n : p.scenario.nodes.nrt)
      need(n.workload, n.core);
  }
  // Measurements a resumed folder (or another shard) already holds are not taken again.
  for (const std::string& key : key_order) {
    const Need& n = needs.at(key);
    plan.keys.insert(key);
    const auto held = opened.baselines.all().find(key);
    for (int k = 0; k < n.measurements; ++k) {
      if (held != opened.baselines.all().end() && held->second.runs.count(k)) continue;
      const auto round = static_cast<std::size_t>(baseline_round(k, reps, n.measurements));
      iso_rounds[round].push_back({Task::Kind::Isolation, n.point, k, key, n.workload, n.core});
    }
  }
  // Co-run measurements a resumed folder (or another shard) already holds are not taken again.
  for (std::size_t c = 0; c < corun_plan.measurements.size(); ++c) {
    const std::size_t point = corun_plan.first + c;
    const int measurements = corun_plan.measurements[c];
    for (int k = 0; k < measurements; ++k) {
      if (coruns_held.has(loaded.points[point].sweep.id, k)) continue;
      corun_rounds[static_cast<std::size_t>(baseline_round(k, reps, measurements))].push_back(
          {Task::Kind::Point, point, k, "", nullptr, 0, true});
    }
  }
  const auto add = [&](std::vector<Task> phase) {
    plan.tasks += phase.size();
    for (const Task& t : phase)
      plan.runs += t.kind == Task::Kind::Point && !corun_plan.is_corun(t.point) ? 1 : 0;
    if (!phase.empty()) plan.phases.push_back(std::move(phase));
  };
  if (!interleave) {  // every baseline first, then the co-runs, then the points in sweep order
    std::vector<Task> isolation, coruns, points;
    for (auto& r : iso_rounds)
      isolation.insert(isolation.end(), r.begin(), r.end());
    for (auto& r : corun_rounds)
      coruns.insert(coruns.end(), r.begin(), r.end());
    for (auto& r : point_rounds)
      points.insert(points.end(), r.begin(), r.end());
    std::stable_sort(points.begin(), points.end(),
                     [](const Task& a, const Task& b) { return a.point < b.point; });
    add(std::move(isolation));
    add(std::move(coruns));
    add(std::move(points));
    return plan;
  }
  for (std::size_t r = 0; r < iso_rounds.size(); ++r) {
    add(std::move(iso_rounds[r]));
    add(std::move(corun_rounds[r]));
    add(std::move(point_rounds[r]));
  }
  return plan;
}

// --jobs, or the CPUs online when it is 0.
int requested_jobs(const RunOptions& opt) {
  return opt.jobs > 0 ? opt.jobs : static_cast<int>(::sysconf(_SC_NPROCESSORS_ONLN));
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
      const std::string label = t.kind == Task::Kind::Isolation
                                    ? "isolation " + t.iso_key + " #" + std::to_string(t.rep)
                                : corun ? "unregulated co-run " + loaded_.points[t.point].sweep.id +
                                              " #" + std::to_string(t.rep)
                                        : point_label(loaded_.points[t.point].sweep, t.rep);
      if (r.interrupted || (stop_signal() && !r.ok)) {
        interrupted_ = true;
        continue;
      }
      if (!r.ok) {
        if (failure_.empty()) failure_ = label + ": " + r.error;
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
bool run_tasks(const TaskPlan& plan, const CorunPlan& corun_plan, RunState& st,
               const ResultsStore& store, TaskRunner& runner, InvocationReport& report,
               json& trace_events) {
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
        held.emplace(position, run_rows(r, lp, t.rep, st));
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
                   std::size_t points, int reps) {
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
    std::cout << "rosguard: " << report.rows << " run(s) of " << points << " point(s) x " << reps
              << " repetition(s) written to " << out.string() << " in " << elapsed << "\n";
  }
  return 0;
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
  loader.load_points(loaded);
  std::unique_ptr<Backend> backend = make_backend(loaded, backends);
  const Scenario& first = loaded.points.front().scenario;
  std::map<std::string, std::size_t> order;
  for (const auto& p : loaded.points)
    order.emplace(p.sweep.id, p.sweep.index);

  // 2. The results folder: new, resumed, or shared with other shards of the same scenario.
  ResultsStore store(results_folder(opt, loaded), join(header_of(loaded), ","), order,
                     first.repetitions);
  store.prepare(opt.overwrite, opt.resume || opt.shard_count > 1, scenario_hash(loaded));
  std::error_code ec;
  if (opt.overwrite) fs::remove(store.dir() / "unregulated.json", ec);
  const ResultsStore::Opened opened =
      store.open(describe_run(loaded, first.backend, opt.command_line),
                 std::to_string(opt.shard_index) + "/" + std::to_string(opt.shard_count));
  const int repetitions = first.repetitions;
  const std::size_t point_count = loaded.points.size();

  // 3. Tasks of this shard; 4. run them; 5. sort the rows (so --jobs and shards do not change
  // the bytes) and finish the manifest, also when something throws.
  InvocationReport report;
  CorunPlan corun_plan;
  // Rows another invocation or shard wrote, or rows written before a measurement they use, are
  // brought up to date when the run finishes; a fresh single-shard run that measured every
  // baseline and co-run before its first row has none (the refresh reads every row: 0.3 s for
  // 10,000 points).
  bool refresh_rows = true;
  try {
    // The co-run points are appended: `first` and other references into the points are stale.
    corun_plan = add_corun_points(loaded, opt, *backend);
    UnregulatedCoruns coruns = UnregulatedCoruns::read(store.dir());
    const TaskPlan plan = plan_tasks(loaded, opt, opened, *backend, corun_plan, coruns);
    const bool elsewhere = std::any_of(
        loaded.points.begin(), loaded.points.end(),
        [](const LoadedPoint& p) { return UnregulatedCoruns::signalled_elsewhere(p.scenario); });
    report.facts["unregulated_corun"] =
        !opt.unregulated ? "off (rosguard run --no-unregulated)"
        : elsewhere      ? "not measured where an RT node is signalled by a topic (another "
                           "program's jobs cannot run twice); elsewhere once per co-run "
                           "(unregulated.json)"
                         : "measured once per co-run of the nodes with policy none "
                           "(unregulated.json)";
    report.skipped_on_resume = plan.skipped;
    if (plan.skipped > 0 && !opt.quiet)
      std::cerr << "resume: " << plan.skipped << " run(s) already in "
                << store.points_path().string() << ", skipped\n";
    RunState st{&loaded,   backend.get(),     opened.baselines,
                opt.trace, header_of(loaded), std::move(coruns)};
    std::vector<TaskHost*> host_ptrs;
    for (const auto& h : hosts)
      host_ptrs.push_back(h.get());
    auto exec =
        make_executor(st, backend->process_per_task(), worker_count(opt, *backend), host_ptrs);
    StopSignalGuard signals;
    Progress progress(plan.runs, !opt.quiet);
    TaskRunner runner(loaded, corun_plan, *exec, progress, report, opened.fallbacks);
    json trace_events = json::array();
    const bool measured_after_rows =
        run_tasks(plan, corun_plan, st, store, runner, report, trace_events);
    refresh_rows = measured_after_rows || opt.shard_count > 1 || !opened.done.empty();
    progress.finish();
    warn_noisy_baselines(plan, st.baselines);
    if (opt.trace && !trace_events.empty()) store.add_trace(trace_events);
    report.error = runner.failure();
    report.status = !report.error.empty()  ? "failed"
                    : runner.interrupted() ? "interrupted"
                                           : "complete";
    report.elapsed_s = progress.seconds();
  } catch (const std::exception& e) {
    report.status = "failed";
    report.error = e.what();
    try {
      store.finish(report, row_refresher(loaded, corun_plan, store.dir()));
    } catch (const std::exception&) {  // the first error is the one to report
    }
    throw;
  }
  store.finish(report,
               refresh_rows ? row_refresher(loaded, corun_plan, store.dir()) : RowRefresher{});
  return report_to_user(opt, report, store.dir(), point_count, repetitions);
}

}  // namespace rosguard

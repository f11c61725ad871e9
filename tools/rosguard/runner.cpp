#include "runner.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/utsname.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <deque>
#include <fstream>
#include <iostream>
#include <map>
#include <set>

#include "core/error.h"
#include "core/hash.h"
#include "files.h"
#include "results/results.h"
#include "version.h"

namespace rosguard {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// ---------------------------------------------------------------------------------------------
// Signals: SIGINT / SIGTERM only set a flag; the run stops dispatching and finishes cleanly.

volatile std::sig_atomic_t g_stop_signal = 0;

extern "C" void on_stop_signal(int sig) {
  g_stop_signal = sig;
}

class SignalGuard {
 public:
  SignalGuard() {
    g_stop_signal = 0;
    struct sigaction sa {};
    sa.sa_handler = on_stop_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = 0;  // no SA_RESTART: blocking calls return EINTR and see the flag
    sigaction(SIGINT, &sa, &old_int_);
    sigaction(SIGTERM, &sa, &old_term_);
  }
  ~SignalGuard() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }
  SignalGuard(const SignalGuard&) = delete;
  SignalGuard& operator=(const SignalGuard&) = delete;

 private:
  struct sigaction old_int_ {};
  struct sigaction old_term_ {};
};

// ---------------------------------------------------------------------------------------------
// Trace: Chrome trace event JSON, one "process" per point and repetition, one "thread" per
// (core, track).

class ChromeTrace : public TraceSink {
 public:
  explicit ChromeTrace(int pid) : pid_(pid) {}

  void span(TimeNs begin, TimeNs end, int core, std::string_view track,
            std::string_view name) override {
    events_.push_back({{"ph", "X"},
                       {"pid", pid_},
                       {"tid", tid(core, track)},
                       {"name", name},
                       {"ts", us(begin)},
                       {"dur", us(std::max<TimeNs>(0, end - begin))}});
  }
  void counter(TimeNs t, int core, std::string_view name, double value) override {
    events_.push_back({{"ph", "C"},
                       {"pid", pid_},
                       {"name", "core " + std::to_string(core) + " " + std::string(name)},
                       {"ts", us(t)},
                       {"args", {{std::string(name), value}}}});
  }
  void instant(TimeNs t, int core, std::string_view track, std::string_view name) override {
    events_.push_back({{"ph", "i"},
                       {"s", "t"},
                       {"pid", pid_},
                       {"tid", tid(core, track)},
                       {"name", name},
                       {"ts", us(t)}});
  }

  json take(const std::string& process_name) {
    json out = json::array();
    out.push_back(
        {{"ph", "M"}, {"pid", pid_}, {"name", "process_name"}, {"args", {{"name", process_name}}}});
    out.push_back({{"ph", "M"},
                   {"pid", pid_},
                   {"name", "process_sort_index"},
                   {"args", {{"sort_index", pid_}}}});
    for (const auto& [key, id] : tids_)
      out.push_back(
          {{"ph", "M"},
           {"pid", pid_},
           {"tid", id},
           {"name", "thread_name"},
           {"args", {{"name", "core " + std::to_string(key.first) + ": " + key.second}}}});
    for (auto& e : events_)
      out.push_back(std::move(e));
    events_.clear();
    return out;
  }

 private:
  static double us(TimeNs t) { return static_cast<double>(t) / 1e3; }
  int tid(int core, std::string_view track) {
    const auto key = std::make_pair(core, std::string(track));
    auto it = tids_.find(key);
    if (it != tids_.end()) return it->second;
    const int id = core * 100 + static_cast<int>(tids_.size()) + 1;
    tids_[key] = id;
    return id;
  }

  int pid_;
  std::vector<json> events_;
  std::map<std::pair<int, std::string>, int> tids_;
};

// ---------------------------------------------------------------------------------------------
// Tasks and their results (serialised as JSON when they come back from a worker process).

struct Task {
  enum class Kind { Isolation, Point } kind = Kind::Point;
  std::size_t point = 0;  // index into the loaded points (isolation: a point that uses it)
  int rep = 0;
  std::string iso_key;
  const WorkloadInfo* workload = nullptr;
  int core = 0;
};

struct TaskResult {
  bool ok = false;
  bool interrupted = false;
  bool input_error = false;
  std::string error;
  IsolationResult iso;
  PointOutcome outcome;
  std::vector<std::pair<std::string, std::string>> fallbacks;
  std::map<std::string, std::string> facts;
  json trace = json::array();
};

json to_json(const TaskResult& r) {
  json j;
  j["ok"] = r.ok;
  j["interrupted"] = r.interrupted;
  j["input_error"] = r.input_error;
  j["error"] = r.error;
  j["iso"] = {r.iso.time_us, r.iso.ipc, r.iso.mbps};
  json rt = json::array(), nrt = json::array(), samples = json::array();
  for (const auto& n : r.outcome.rt)
    rt.push_back({n.name, n.time_us, n.jobs});
  for (const auto& n : r.outcome.nrt)
    nrt.push_back({n.name, n.time_us, n.bandwidth_mbps, n.throttle_count, n.throttled_us, n.runs});
  for (const auto& s : r.outcome.samples)
    samples.push_back({s.kind, s.value_us});
  j["rt"] = rt;
  j["nrt"] = nrt;
  j["samples"] = samples;
  j["fallbacks"] = r.fallbacks;
  j["facts"] = r.facts;
  j["trace"] = r.trace;
  return j;
}

TaskResult from_json(const json& j) {
  TaskResult r;
  r.ok = j.at("ok");
  r.interrupted = j.at("interrupted");
  r.input_error = j.at("input_error");
  r.error = j.at("error");
  r.iso = {j["iso"][0], j["iso"][1], j["iso"][2]};
  for (const auto& n : j["rt"])
    r.outcome.rt.push_back({n[0], n[1], n[2]});
  for (const auto& n : j["nrt"])
    r.outcome.nrt.push_back({n[0], n[1], n[2], n[3], n[4], n[5]});
  for (const auto& s : j["samples"])
    r.outcome.samples.push_back({s[0], s[1]});
  r.fallbacks = j["fallbacks"].get<std::vector<std::pair<std::string, std::string>>>();
  r.facts = j["facts"].get<std::map<std::string, std::string>>();
  r.trace = j["trace"];
  return r;
}

class TaskContext : public RunContext {
 public:
  TaskContext(TaskResult& result, ChromeTrace* trace) : result_(result), trace_(trace) {}
  void fallback(const std::string& what, const std::string& detail) override {
    result_.fallbacks.emplace_back(what, detail);
  }
  void fact(const std::string& key, const std::string& value) override {
    result_.facts[key] = value;
  }
  TraceSink* trace() override { return trace_; }
  bool stop_requested() const override { return g_stop_signal != 0; }

 private:
  TaskResult& result_;
  ChromeTrace* trace_;
};

struct RunState {
  const LoadedScenario* loaded = nullptr;
  Backend* backend = nullptr;
  Baselines baselines;
  bool trace = false;
};

std::string point_label(const SweepPoint& p, int rep) {
  std::string s = "point " + p.id + " rep " + std::to_string(rep);
  std::string params;
  for (const auto& q : p.params)
    params += (params.empty() ? "" : ", ") + q.path + "=" +
              (q.value.is_string() ? q.value.get<std::string>() : q.value.dump());
  return params.empty() ? s : s + " (" + params + ")";
}

TaskResult execute(const Task& task, const RunState& st) {
  TaskResult r;
  const LoadedPoint& lp = st.loaded->points[task.point];
  const int reps = lp.scenario.repetitions;
  ChromeTrace trace(static_cast<int>(task.point) * reps + task.rep + 1);
  TaskContext ctx(r, st.trace && task.kind == Task::Kind::Point ? &trace : nullptr);
  try {
    if (task.kind == Task::Kind::Isolation) {
      r.iso = st.backend->isolation(lp.scenario, *task.workload, task.core,
                                    task_seed(lp.scenario.seed, task.iso_key, 0), ctx);
    } else {
      r.outcome = st.backend->run_point(lp.scenario, st.baselines, task.rep,
                                        task_seed(lp.scenario.seed, lp.sweep.id, task.rep), ctx);
      if (st.trace) r.trace = trace.take(point_label(lp.sweep, task.rep));
    }
    r.ok = true;
  } catch (const Interrupted&) {
    r.interrupted = true;
    r.error = "interrupted";
  } catch (const InputError& e) {
    r.input_error = true;
    r.error = e.what();
  } catch (const std::exception& e) {
    r.error = e.what();
  }
  return r;
}

// ---------------------------------------------------------------------------------------------
// Executors: in-process, or one forked worker per task with up to `jobs` at a time.

class Executor {
 public:
  virtual ~Executor() = default;
  virtual bool can_submit() const = 0;
  virtual void submit(std::size_t id, const Task& task) = 0;
  virtual bool busy() const = 0;
  // Blocks until a task finishes; returns its id and result.
  virtual std::pair<std::size_t, TaskResult> wait_one() = 0;
  virtual void stop_all() = 0;
};

class InProcessExecutor : public Executor {
 public:
  explicit InProcessExecutor(const RunState& st) : st_(st) {}
  bool can_submit() const override { return !pending_; }
  void submit(std::size_t id, const Task& task) override {
    pending_ = std::make_pair(id, execute(task, st_));
  }
  bool busy() const override { return pending_.has_value(); }
  std::pair<std::size_t, TaskResult> wait_one() override {
    auto out = std::move(*pending_);
    pending_.reset();
    return out;
  }
  void stop_all() override {}

 private:
  const RunState& st_;
  std::optional<std::pair<std::size_t, TaskResult>> pending_;
};

class ForkExecutor : public Executor {
 public:
  ForkExecutor(const RunState& st, int jobs) : st_(st), jobs_(jobs) {}
  ~ForkExecutor() override { stop_all(); }

  bool can_submit() const override { return static_cast<int>(workers_.size()) < jobs_; }
  bool busy() const override { return !workers_.empty(); }

  void submit(std::size_t id, const Task& task) override {
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0) throw RunError(std::string("pipe: ") + std::strerror(errno));
    std::cout.flush();
    std::cerr.flush();
    const pid_t pid = ::fork();
    if (pid < 0) throw RunError(std::string("fork: ") + std::strerror(errno));
    if (pid == 0) {
      // Worker: default signal handling (a terminal's Ctrl-C reaches the whole process group),
      // run the task, send the result, leave without running the parent's destructors.
      ::signal(SIGINT, SIG_DFL);
      ::signal(SIGTERM, SIG_DFL);
      ::close(fds[0]);
      std::string payload;
      try {
        payload = to_json(execute(task, st_)).dump();
      } catch (const std::exception& e) {
        TaskResult r;
        r.error = e.what();
        payload = to_json(r).dump();
      }
      const char* p = payload.data();
      std::size_t left = payload.size();
      while (left > 0) {
        const ssize_t n = ::write(fds[1], p, left);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) ::_exit(3);
        p += n;
        left -= static_cast<std::size_t>(n);
      }
      ::_exit(0);
    }
    ::close(fds[1]);
    workers_.push_back({id, pid, fds[0], {}});
  }

  std::pair<std::size_t, TaskResult> wait_one() override {
    while (true) {
      std::vector<pollfd> pfds;
      for (const auto& w : workers_)
        pfds.push_back({w.fd, POLLIN, 0});
      const int n = ::poll(pfds.data(), pfds.size(), 200);
      if (n < 0 && errno != EINTR) throw RunError(std::string("poll: ") + std::strerror(errno));
      for (std::size_t i = 0; n > 0 && i < pfds.size(); ++i) {
        if (!(pfds[i].revents & (POLLIN | POLLHUP | POLLERR))) continue;
        Worker& w = workers_[i];
        char buf[65536];
        const ssize_t got = ::read(w.fd, buf, sizeof buf);
        if (got > 0) {
          w.data.append(buf, static_cast<std::size_t>(got));
          continue;
        }
        if (got < 0 && errno == EINTR) continue;
        return finish(i);  // EOF (or a read error): the worker is done
      }
    }
  }

  void stop_all() override {
    for (const auto& w : workers_)
      ::kill(w.pid, SIGTERM);
    for (const auto& w : workers_) {
      int status = 0;
      while (::waitpid(w.pid, &status, 0) < 0 && errno == EINTR) {
      }
      ::close(w.fd);
    }
    workers_.clear();
  }

 private:
  struct Worker {
    std::size_t id;
    pid_t pid;
    int fd;
    std::string data;
  };

  std::pair<std::size_t, TaskResult> finish(std::size_t i) {
    Worker w = std::move(workers_[i]);
    workers_.erase(workers_.begin() + static_cast<std::ptrdiff_t>(i));
    ::close(w.fd);
    int status = 0;
    while (::waitpid(w.pid, &status, 0) < 0 && errno == EINTR) {
    }
    TaskResult r;
    if (WIFSIGNALED(status)) {
      const int sig = WTERMSIG(status);
      r.interrupted = g_stop_signal != 0 && (sig == SIGINT || sig == SIGTERM);
      r.error = r.interrupted ? "interrupted"
                              : "worker process died with signal " + std::to_string(sig) + " (" +
                                    strsignal(sig) + ")";
      return {w.id, r};
    }
    try {
      r = from_json(json::parse(w.data));
    } catch (const std::exception& e) {
      r = TaskResult{};
      r.error = "worker process exited with status " +
                std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) +
                " and no readable result";
    }
    return {w.id, r};
  }

  const RunState& st_;
  int jobs_;
  std::vector<Worker> workers_;
};

// ---------------------------------------------------------------------------------------------
// Manifest helpers.

std::string iso_time_now() {
  const auto now = std::chrono::system_clock::now();
  const std::time_t t = std::chrono::system_clock::to_time_t(now);
  std::tm tm{};
  ::gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

json host_facts() {
  json h;
  utsname u{};
  if (::uname(&u) == 0) {
    h["hostname"] = u.nodename;
    h["kernel"] = std::string(u.sysname) + " " + u.release;
    h["machine"] = u.machine;
  }
  h["cpus_online"] = ::sysconf(_SC_NPROCESSORS_ONLN);
  std::ifstream cpuinfo("/proc/cpuinfo");
  std::string line;
  while (std::getline(cpuinfo, line)) {
    if (line.rfind("model name", 0) == 0 || line.rfind("Hardware", 0) == 0) {
      h["cpu_model"] = line.substr(line.find(':') + 2);
      break;
    }
  }
  return h;
}

// The revision is the one baked in when the build was configured: an installed rosguard has no
// source tree to ask, and a results folder must not depend on where it was written from.
json tool_facts() {
  return {{"name", "rosguard"},
          {"version", kVersion},
          {"git_revision", kGitRevision},
          {"build_type", kBuildType}};
}

// What must match for a results folder to be resumed or shared by shards: everything that
// changes results (not the name, description, or the number of repetitions).
std::string scenario_hash(const LoadedScenario& s) {
  json j = s.expanded;
  for (const char* k : {"name", "description", "repetitions", "$schema"})
    j.erase(k);
  char buf[20];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(fnv1a(j.dump())));
  return buf;
}

// ---------------------------------------------------------------------------------------------
// Progress on a terminal.

class Progress {
 public:
  Progress(std::size_t total, bool enabled)
      : total_(total), enabled_(enabled && ::isatty(STDERR_FILENO)), start_(clock::now()) {}
  void update(std::size_t done, const std::string& what) {
    if (!enabled_) return;
    const double elapsed = seconds();
    char line[256];
    const double eta =
        done ? elapsed * static_cast<double>(total_ - done) / static_cast<double>(done) : 0;
    std::snprintf(line, sizeof line, "\r\033[K[%zu/%zu] %3.0f%%  %.1fs elapsed, ETA %.1fs  %s",
                  done, total_,
                  total_ ? 100.0 * static_cast<double>(done) / static_cast<double>(total_) : 100.0,
                  elapsed, eta, what.substr(0, 80).c_str());
    std::cerr << line << std::flush;
  }
  void finish() {
    if (enabled_) std::cerr << "\r\033[K" << std::flush;
  }
  double seconds() const { return std::chrono::duration<double>(clock::now() - start_).count(); }

 private:
  using clock = std::chrono::steady_clock;
  std::size_t total_;
  bool enabled_;
  clock::time_point start_;
};

struct RowKey {
  std::size_t point;
  int rep;
  auto operator<=>(const RowKey&) const = default;
};

// Rewrites a CSV (header + rows) sorted by (point order, rep), keeping the first row of each
// duplicate key for points.csv, every row (stable) for samples.csv.
void sort_csv(const fs::path& path, const std::map<std::string, std::size_t>& order, bool unique) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return;
  auto lines = split_lines(read_file(path));
  if (lines.empty()) return;
  const std::string header = lines.front();
  std::vector<std::pair<RowKey, std::string>> rows;
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const auto cells = csv_split(lines[i]);
    if (cells.size() < 2) continue;
    auto it = order.find(cells[0]);
    const std::size_t idx = it == order.end() ? order.size() : it->second;
    rows.push_back({{idx, std::atoi(cells[1].c_str())}, lines[i]});
  }
  std::stable_sort(rows.begin(), rows.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  std::string out = header + "\n";
  std::set<RowKey> seen;
  for (const auto& [key, line] : rows) {
    if (unique && !seen.insert(key).second) continue;
    out += line + "\n";
  }
  write_file_atomic(path, out);
}

std::string join(const std::vector<std::string>& v, const std::string& sep) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i)
    s += (i ? sep : "") + v[i];
  return s;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

int run_scenario(const RunOptions& opt, Loader& loader, const BackendRegistry& backends) {
  // 1. Load and validate everything; errors here are InputErrors and nothing is written.
  LoadedScenario loaded = loader.load(opt.scenario_file, opt.backend);
  const std::string backend_name = loaded.points.front().scenario.backend;
  const BackendInfo* info = backends.find(backend_name);
  if (!info) {
    std::string known;
    for (const auto& b : backends.all())
      known += (known.empty() ? "" : ", ") + b.name;
    throw RunError("the " + backend_name + " backend is not built into this rosguard (built: " +
                   (known.empty() ? "none" : known) + ")");
  }
  std::unique_ptr<Backend> backend = info->make();
  for (const auto& p : loaded.points)
    backend->validate(p.scenario);
  // The loader's warnings (e.g. a controller sharing a core) go to the manifest; the backend
  // says what they mean for this run (as a fallback), so they are not printed twice.

  const Scenario& first = loaded.points.front().scenario;
  const fs::path out = opt.out.empty() ? fs::path("results") / first.name : opt.out;
  const int reps = first.repetitions;
  const std::string hash = scenario_hash(loaded);

  std::size_t max_rt = 0, max_nrt = 0;
  for (const auto& p : loaded.points) {
    max_rt = std::max(max_rt, p.scenario.nodes.rt.size());
    max_nrt = std::max(max_nrt, p.scenario.nodes.nrt.size());
  }
  const std::vector<std::string> header = points_header(max_rt, max_nrt, loaded.sweep_paths);
  const std::string header_line = join(header, ",");
  std::map<std::string, std::size_t> order;
  for (const auto& p : loaded.points)
    order.emplace(p.sweep.id, p.sweep.index);

  // 2. The results folder: new, resumed, or shared with other shards of the same scenario.
  std::error_code ec;
  const fs::path manifest_path = out / "manifest.json";
  const fs::path points_path = out / "points.csv";
  const fs::path samples_path = out / "samples.csv";
  const fs::path baselines_path = out / "baselines.json";
  const fs::path trace_path = out / "trace.json";
  const fs::path lock_path = out / ".lock";
  const bool joining = opt.resume || opt.shard_count > 1;
  if (fs::exists(manifest_path, ec) || fs::exists(points_path, ec)) {
    if (opt.overwrite) {
      for (const auto& f :
           {manifest_path, points_path, samples_path, baselines_path, trace_path, lock_path})
        fs::remove(f, ec);
    } else if (!joining) {
      throw InputError("", "",
                       "results folder " + out.string() +
                           " already holds a run; pass --resume to continue it, "
                           "--overwrite to replace it, or choose another --out");
    } else if (fs::exists(manifest_path, ec)) {
      const json m = json::parse(read_file(manifest_path), nullptr, false);
      if (!m.is_object() || m.value("scenario_hash", "") != hash)
        throw InputError("", "",
                         "results folder " + out.string() +
                             " holds a different scenario (or other settings); resume "
                             "only the same scenario, or choose another --out");
    }
  }
  fs::create_directories(out, ec);
  if (ec) throw RunError("cannot create results folder " + out.string() + ": " + ec.message());

  json manifest;
  std::set<std::pair<std::string, int>> done;
  RunState st;
  st.loaded = &loaded;
  st.backend = backend.get();
  st.trace = opt.trace;
  {
    FileLock lock(lock_path);
    manifest = fs::exists(manifest_path, ec) ? json::parse(read_file(manifest_path), nullptr, false)
                                             : json::object();
    if (!manifest.is_object()) manifest = json::object();
    manifest["schema_version"] = 1;
    manifest["tool"] = tool_facts();
    manifest["command"] = opt.command_line;
    manifest["scenario_file"] = loaded.file;
    manifest["scenario_hash"] = hash;
    manifest["scenario"] = {{"given", loaded.given}, {"expanded", loaded.expanded}};
    json points_json = json::array();
    std::map<std::string, json> platforms;
    for (const auto& p : loaded.points) {
      json params = json::object();
      for (const auto& q : p.sweep.params)
        params[q.path] = q.value;
      points_json.push_back({{"index", p.sweep.index}, {"id", p.sweep.id}, {"params", params}});
      platforms.emplace(p.scenario.platform.name, json{{"origin", p.scenario.platform.origin},
                                                       {"doc", p.scenario.platform.doc}});
    }
    manifest["scenario"]["points"] = points_json;
    // Every workload the run uses, with the isolation figures it is calibrated against (the
    // paper's Table 1), so that analysis can show measured next to reference.
    json workloads = json::object();
    for (const auto& p : loaded.points) {
      const auto add = [&](const WorkloadInfo& w) {
        json entry{{"origin", w.origin}};
        if (w.doc.contains("reference")) entry["reference"] = w.doc["reference"];
        workloads[w.name] = entry;
      };
      for (const auto& n : p.scenario.nodes.rt)
        add(n.workload);
      for (const auto& n : p.scenario.nodes.nrt)
        add(n.workload);
    }
    manifest["workloads"] = workloads;
    manifest["platform"] = platforms.size() == 1 ? platforms.begin()->second : json(platforms);
    manifest["backend"] = backend_name;
    manifest["seed"] = first.seed;
    manifest["repetitions"] = reps;
    manifest["host"] = host_facts();
    manifest["shard"] = std::to_string(opt.shard_index) + "/" + std::to_string(opt.shard_count);
    manifest["start_time"] = iso_time_now();
    manifest["end_time"] = nullptr;
    manifest["status"] = "running";
    manifest["warnings"] = loaded.warnings;
    if (!manifest.contains("fallbacks")) manifest["fallbacks"] = json::array();
    if (!manifest.contains("facts")) manifest["facts"] = json::object();
    write_file_atomic(manifest_path, manifest.dump(2) + "\n");

    // points.csv: header checked on resume, a torn tail cut; samples of unfinished rows dropped.
    if (fs::exists(points_path, ec)) {
      truncate_torn_tail(points_path);
      const auto lines = split_lines(read_file(points_path));
      if (!lines.empty() && lines.front() != header_line)
        throw InputError("", "",
                         points_path.string() +
                             " has other columns than this scenario produces; resume "
                             "only the same scenario, or choose another --out");
      for (std::size_t i = 1; i < lines.size(); ++i) {
        const auto cells = csv_split(lines[i]);
        if (cells.size() >= 2) done.emplace(cells[0], std::atoi(cells[1].c_str()));
      }
      if (lines.empty()) write_file_atomic(points_path, header_line + "\n");
    } else {
      write_file_atomic(points_path, header_line + "\n");
    }
    std::string kept = std::string(kSamplesHeader) + "\n";
    if (fs::exists(samples_path, ec)) {
      truncate_torn_tail(samples_path);
      const auto lines = split_lines(read_file(samples_path));
      for (std::size_t i = 1; i < lines.size(); ++i) {
        const auto cells = csv_split(lines[i]);
        if (cells.size() >= 2 && done.count({cells[0], std::atoi(cells[1].c_str())}))
          kept += lines[i] + "\n";
      }
    }
    write_file_atomic(samples_path, kept);
    if (fs::exists(baselines_path, ec)) {
      const json b = json::parse(read_file(baselines_path), nullptr, false);
      if (b.is_object())
        for (const auto& [k, v] : b.items())
          st.baselines.put(k, {v.at("time_us"), v.at("ipc"), v.at("mbps")});
    }
  }

  // 3. Tasks of this shard: the isolation baselines not known yet, then points x repetitions.
  std::vector<Task> iso_tasks, point_tasks;
  std::set<std::string> iso_seen;
  std::size_t skipped = 0;
  for (const auto& p : loaded.points) {
    if (static_cast<int>(p.sweep.index % static_cast<std::size_t>(opt.shard_count)) !=
        opt.shard_index)
      continue;
    bool any = false;
    for (int rep = 0; rep < reps; ++rep) {
      if (done.count({p.sweep.id, rep})) {
        ++skipped;
        continue;
      }
      Task t;
      t.kind = Task::Kind::Point;
      t.point = p.sweep.index;
      t.rep = rep;
      point_tasks.push_back(t);
      any = true;
    }
    if (!any) continue;
    const auto need = [&](const WorkloadInfo& w, int core) {
      const std::string key = Baselines::key(p.scenario, w, core);
      if (st.baselines.all().count(key) || !iso_seen.insert(key).second) return;
      Task t;
      t.kind = Task::Kind::Isolation;
      t.point = p.sweep.index;
      t.iso_key = key;
      t.workload = &w;
      t.core = core;
      iso_tasks.push_back(t);
    };
    for (const auto& n : p.scenario.nodes.rt)
      need(n.workload, n.core);
    for (const auto& n : p.scenario.nodes.nrt)
      need(n.workload, n.core);
  }
  if (skipped > 0 && !opt.quiet)
    std::cerr << "resume: " << skipped << " run(s) already in " << points_path.string()
              << ", skipped\n";

  int jobs = opt.jobs > 0 ? opt.jobs : static_cast<int>(::sysconf(_SC_NPROCESSORS_ONLN));
  if (!backend->process_per_task() && jobs > 1) {
    if (opt.jobs > 1)
      std::cerr << "note: the " << backend_name
                << " backend measures one point at a time; --jobs ignored\n";
    jobs = 1;
  }
  std::unique_ptr<Executor> exec;
  if (backend->process_per_task())
    exec = std::make_unique<ForkExecutor>(st, std::max(1, jobs));
  else
    exec = std::make_unique<InProcessExecutor>(st);

  // 4. Run. Rows are appended as points finish: samples first, then the point's row, each in
  // one write(), so a killed run leaves only complete rows (and resume drops orphan samples).
  SignalGuard signals;
  Progress progress(iso_tasks.size() + point_tasks.size(), !opt.quiet);
  std::string failure;
  bool interrupted = false;
  std::size_t finished = 0, rows = 0;
  json trace_events = json::array();
  std::set<std::pair<std::string, std::string>> fallbacks_seen;
  for (const auto& f : manifest["fallbacks"])
    fallbacks_seen.emplace(f.value("what", ""), f.value("detail", ""));

  const auto absorb = [&](const TaskResult& r) {
    for (const auto& [what, detail] : r.fallbacks)
      if (fallbacks_seen.emplace(what, detail).second) {
        progress.finish();
        std::cerr << "warning: fallback (" << what << "): " << detail << "\n";
        manifest["fallbacks"].push_back({{"what", what}, {"detail", detail}});
      }
    for (const auto& [k, v] : r.facts)
      manifest["facts"][k] = v;
  };

  const auto run_phase = [&](const std::vector<Task>& tasks, const auto& on_result) {
    std::size_t next = 0;
    while (true) {
      while (next < tasks.size() && exec->can_submit() && failure.empty() && !g_stop_signal) {
        exec->submit(next, tasks[next]);
        ++next;
      }
      if (g_stop_signal) exec->stop_all();
      if (!exec->busy()) break;
      auto [id, r] = exec->wait_one();
      ++finished;
      const Task& t = tasks[id];
      const std::string label = t.kind == Task::Kind::Isolation
                                    ? "isolation " + t.iso_key
                                    : point_label(loaded.points[t.point].sweep, t.rep);
      if (r.interrupted || (g_stop_signal && !r.ok)) {
        interrupted = true;
        continue;
      }
      if (!r.ok) {
        if (failure.empty()) failure = label + ": " + r.error;
        continue;
      }
      absorb(r);
      on_result(t, r);
      progress.update(finished, label);
    }
  };

  run_phase(iso_tasks,
            [&](const Task& t, const TaskResult& r) { st.baselines.put(t.iso_key, r.iso); });
  if (!iso_tasks.empty()) {
    FileLock lock(lock_path);
    json b = fs::exists(baselines_path, ec) ? json::parse(read_file(baselines_path), nullptr, false)
                                            : json::object();
    if (!b.is_object()) b = json::object();
    for (const auto& [k, v] : st.baselines.all())
      b[k] = {{"time_us", v.time_us}, {"ipc", v.ipc}, {"mbps", v.mbps}};
    write_file_atomic(baselines_path, b.dump(2) + "\n");
  }

  if (failure.empty() && !g_stop_signal) {
    AppendFile points_file(points_path);
    AppendFile samples_file(samples_path);
    run_phase(point_tasks, [&](const Task& t, const TaskResult& r) {
      const LoadedPoint& lp = loaded.points[t.point];
      samples_file.append(samples_rows(lp.sweep.id, t.rep, r.outcome));
      points_file.append(points_row(header, lp.sweep, lp.scenario, t.rep, r.outcome, st.baselines));
      ++rows;
      for (const auto& e : r.trace)
        trace_events.push_back(e);
    });
    points_file.sync();
    samples_file.sync();
  }
  progress.finish();
  if (g_stop_signal) interrupted = true;

  // 5. Finish: rows in canonical order (so --jobs and shards do not change the bytes), trace,
  // manifest.
  {
    FileLock lock(lock_path);
    sort_csv(points_path, order, true);
    sort_csv(samples_path, order, false);
    if (opt.trace && !trace_events.empty())
      write_file_atomic(
          trace_path, json{{"traceEvents", trace_events}, {"displayTimeUnit", "ms"}}.dump() + "\n");
    const std::size_t total_rows = split_lines(read_file(points_path)).size() - 1;
    manifest["end_time"] = iso_time_now();
    manifest["status"] = !failure.empty() ? "failed" : interrupted ? "interrupted" : "complete";
    if (!failure.empty()) manifest["error"] = failure;
    manifest["counts"] = {{"points", loaded.points.size()},
                          {"repetitions", reps},
                          {"runs_expected", loaded.points.size() * static_cast<std::size_t>(reps)},
                          {"rows", total_rows},
                          {"rows_this_invocation", rows},
                          {"skipped_on_resume", skipped}};
    manifest["elapsed_s"] = progress.seconds();
    write_file_atomic(manifest_path, manifest.dump(2) + "\n");
  }

  if (!failure.empty()) {
    std::cerr << "error: " << failure << "\n"
              << "rosguard: " << rows << " run(s) written to " << out.string()
              << " before the failure; complete rows are kept\n";
    return 1;
  }
  if (interrupted) {
    std::cerr << "rosguard: interrupted; " << rows << " complete run(s) kept in " << out.string()
              << " (continue with --resume)\n";
    return g_stop_signal == SIGTERM ? 143 : 130;
  }
  if (!opt.quiet) {
    char elapsed[32];
    std::snprintf(elapsed, sizeof elapsed, "%.2f s", progress.seconds());
    std::cout << "rosguard: " << rows << " run(s) of " << loaded.points.size() << " point(s) x "
              << reps << " repetition(s) written to " << out.string() << " in " << elapsed << "\n";
  }
  return 0;
}

}  // namespace rosguard

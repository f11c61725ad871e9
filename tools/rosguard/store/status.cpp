#include "store/status.h"

#include <signal.h>
#include <sys/utsname.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "core/error.h"
#include "load/files.h"
#include "load/host_facts.h"
#include "results/results.h"
#include "run/slurm.h"

namespace rosguard {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// What status needs of a results folder.
struct Folder {
  std::size_t points = 0;
  int repetitions = 1;
  std::map<std::string, std::size_t> index_of;  // point id -> sweep index (from the manifest)
  std::map<std::size_t, std::size_t> runs_of;   // sweep index -> distinct reps in points.csv
  json shards = json::object();                 // the manifest's entries by "I/N"
  std::string status;                           // the manifest's (as its last writer left it)
  std::string scenario_file;
  std::string backend;  // the one the run used (the manifest's): the re-run must use it too
  std::string command;  // the manifest's
  json job;             // slurm/job.json, or null
};

json read_json_or_throw(const fs::path& path, const fs::path& dir) {
  const json j = json::parse(read_file(path), nullptr, false);
  if (!j.is_object())
    throw InputError(path.string(), "",
                     "not a file rosguard writes, so " + dir.string() +
                         " is not a results folder it can report on");
  return j;
}

Folder read_folder(const fs::path& dir) {
  std::error_code ec;
  const fs::path manifest = dir / "manifest.json", job = dir / "slurm" / "job.json";
  const bool has_manifest = fs::is_regular_file(manifest, ec);
  const bool has_job = fs::is_regular_file(job, ec);
  if (!has_manifest && !has_job)
    throw InputError("", "",
                     dir.string() +
                         (fs::is_directory(dir, ec) ? " is not a results folder (no manifest.json)"
                                                    : " does not exist") +
                         "; rosguard status takes the --out folder of rosguard run");
  Folder f;
  if (has_job) f.job = read_json_or_throw(job, dir);
  if (!has_manifest) {  // submitted, no task started yet
    f.points = f.job.value("points", std::size_t{0});
    f.repetitions = f.job.value("repetitions", 1);
    f.scenario_file = f.job.value("scenario_file", "");
    return f;
  }
  const json m = read_json_or_throw(manifest, dir);
  const json* points = nullptr;
  if (m.contains("scenario") && m["scenario"].is_object() && m["scenario"].contains("points"))
    points = &m["scenario"]["points"];
  if (!points || !points->is_array() || !m.value("repetitions", json()).is_number_integer())
    throw InputError(manifest.string(), "/scenario/points",
                     "missing: not the manifest of a rosguard run");
  f.points = points->size();
  f.repetitions = std::max(1, m["repetitions"].get<int>());
  for (const auto& p : *points)
    f.index_of[p.value("id", "")] = p.value("index", std::size_t{0});
  if (m.contains("shards") && m["shards"].is_object()) f.shards = m["shards"];
  f.status = m.value("status", "");
  f.command = m.value("command", "");
  f.backend = m.value("backend", "");
  f.scenario_file = has_job ? f.job.value("scenario_file", "") : m.value("scenario_file", "");

  // Rows: complete lines only (a row being appended now has no '\n' yet), each run once.
  std::string text;
  if (fs::exists(dir / "points.csv", ec)) text = read_file(dir / "points.csv");
  text.erase(text.rfind('\n') == std::string::npos ? 0 : text.rfind('\n') + 1);
  std::set<std::pair<std::size_t, int>> seen;
  // Only the first two cells (point, rep) of each row are read: a point id has no quote or
  // comma, so a row that starts with a quote is no run's.
  std::size_t pos = text.find('\n');
  pos = pos == std::string::npos ? text.size() : pos + 1;
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    end = end == std::string::npos ? text.size() : end;
    const std::string_view line(text.data() + pos, end - pos);
    pos = end + 1;
    const std::size_t c0 = line.find(',');
    if (c0 == std::string_view::npos) continue;
    const std::size_t c1 = std::min(line.find(',', c0 + 1), line.size());
    const auto it = f.index_of.find(std::string(line.substr(0, c0)));
    int rep = -1;
    const auto [ptr, ec_rep] = std::from_chars(line.data() + c0 + 1, line.data() + c1, rep);
    if (ec_rep != std::errc() || ptr != line.data() + c1) continue;
    if (it == f.index_of.end() || rep < 0 || rep >= f.repetitions) continue;
    if (seen.insert({it->second, rep}).second) ++f.runs_of[it->second];
  }
  return f;
}

// "I/N" -> (I, N).
std::optional<std::pair<int, int>> parse_shard_key(const std::string& key) {
  const auto slash = key.find('/');
  if (slash == std::string::npos) return std::nullopt;
  int i = 0, n = 0;
  const auto a = std::from_chars(key.data(), key.data() + slash, i);
  const auto b = std::from_chars(key.data() + slash + 1, key.data() + key.size(), n);
  if (a.ec != std::errc() || b.ec != std::errc() || a.ptr != key.data() + slash ||
      b.ptr != key.data() + key.size() || n < 1 || i < 0 || i >= n)
    return std::nullopt;
  return std::make_pair(i, n);
}

std::string this_host() {
  utsname u{};
  return ::uname(&u) == 0 ? u.nodename : "";
}

struct ShardView {
  int index = 0, count = 1;
  std::size_t points_done = 0, points_total = 0, runs_done = 0, runs_total = 0;
  std::string state;
  bool live = false;  // running, pending or starting: not to be re-run now
};

// Slurm's queue, asked once and only when a shard's state depends on it.
class Queue {
 public:
  const std::vector<SlurmTask>* tasks() {
    if (!asked_) {
      asked_ = true;
      tasks_ = slurm_queue(why_);
    }
    return tasks_ ? &*tasks_ : nullptr;
  }
  const std::string& why() const { return why_; }
  bool failed() const { return asked_ && !tasks_; }

  const SlurmTask* find(const std::string& id) {
    if (const auto* all = tasks())
      for (const auto& t : *all)
        if (t.id == id) return &t;
    return nullptr;
  }
  // The latest job's task `index` whose batch script is `script`.
  const SlurmTask* latest(const fs::path& script, int index) {
    const SlurmTask* best = nullptr;
    std::error_code ec;
    if (const auto* all = tasks())
      for (const auto& t : *all)
        if (t.index == index && (!best || t.job > best->job) &&
            (fs::path(t.command) == script || fs::equivalent(t.command, script, ec)))
          best = &t;
    return best;
  }

 private:
  bool asked_ = false;
  std::optional<std::vector<SlurmTask>> tasks_;
  std::string why_;
};

std::string shortened(std::string s, std::size_t max) {
  if (s.size() > max) s = s.substr(0, max - 3) + "...";
  return s;
}

// A shard that the manifest says runs: is its process still there?
void judge_running(ShardView& v, const json& entry, Queue& queue, const fs::path& dir) {
  const std::string slurm_job = entry.value("slurm_job", "");
  const std::string host = entry.value("host", "");
  const long long pid = entry.value("pid", 0LL);
  if (!slurm_job.empty() && queue.tasks()) {
    const SlurmTask* t = queue.find(slurm_job);
    if (t && slurm_state_live(t->state)) {
      v.state = "running (Slurm " + slurm_job + (host.empty() ? "" : " on " + host) + ")";
      v.live = true;
      return;
    }
    std::error_code ec;
    const fs::path log = dir / "slurm" / (slurm_job + ".out");
    v.state =
        "stopped: Slurm " + slurm_job +
        (t ? " ended " + t->state +
                 (t->reason.empty() || t->reason == "None" ? std::string() : " (" + t->reason + ")")
           : std::string(" is no longer in Slurm's queue")) +
        " without finishing" + (fs::exists(log, ec) ? "; log " + log.string() : "");
    return;
  }
  if (!host.empty() && host == this_host() && pid > 0) {
    const auto pid_t_value = static_cast<pid_t>(pid);
    const auto ticks = process_start_ticks(pid_t_value);
    const bool same = ticks && (!entry.contains("pid_start") ||
                                entry["pid_start"].get<unsigned long long>() == *ticks);
    if (same) {
      v.state = "running (pid " + std::to_string(pid) + ")";
      v.live = true;
    } else {
      v.state = "stopped: its process (pid " + std::to_string(pid) +
                ") is gone without finishing (killed?)";
    }
    return;
  }
  v.state = "running" + (host.empty() ? std::string() : " on " + host) +
            (pid > 0 ? " (pid " + std::to_string(pid) + ")" : std::string()) +
            (slurm_job.empty() ? "" : " (Slurm " + slurm_job + ")") + ", as far as " +
            (queue.failed() ? "its manifest entry says (" + queue.why() + ")"
                            : std::string("this host can tell"));
  v.live = true;
}

void judge(ShardView& v, const json* entry, Queue& queue, const fs::path& dir,
           const fs::path& script, bool of_script) {
  const std::string status = entry ? entry->value("status", "") : "";
  if (status == "complete") {
    v.state = "complete";
  } else if (status == "failed") {
    v.state = "failed: " + shortened(entry->value("error", "(no message)"), 160);
  } else if (status == "interrupted") {
    v.state = "interrupted";
  } else if (status == "running") {
    judge_running(v, *entry, queue, dir);
  } else {
    v.state = "not started";
  }
  if (v.live || status == "complete" || !of_script) return;
  // Submitted (again) to Slurm and not running yet, or an array task that ended before rosguard
  // wrote its entry (e.g. the node could not start it): the queue knows.
  const SlurmTask* t = queue.latest(script, v.index);
  if (!t) return;
  const std::string entry_job = entry ? entry->value("slurm_job", "") : "";
  if (slurm_state_live(t->state) && t->id != entry_job) {
    v.state = (status.empty() ? "" : v.state + "; again: ") +
              (t->state == "PENDING" ? "pending" : "starting") + " (Slurm " + t->id + ")";
    v.live = true;
  } else if (status.empty() && !slurm_state_live(t->state)) {
    std::error_code ec;
    const fs::path log = dir / "slurm" / (t->id + ".out");
    v.state = "not started: Slurm " + t->id + " ended " + t->state +
              (fs::exists(log, ec) ? "; log " + log.string() : "");
  }
}

std::string fraction(std::size_t done, std::size_t total) {
  return std::to_string(done) + "/" + std::to_string(total);
}

// A folder's shards and totals, each shard judged.
struct RunView {
  std::vector<ShardView> shards;
  std::size_t points_done = 0, runs_done = 0, runs_total = 0;
  bool live = false;      // a shard runs or is queued
  bool complete = false;  // every run has its row
};

RunView assess(const fs::path& dir, const Folder& f, Queue& queue) {
  const int job_shards = f.job.is_object() ? f.job.value("shards", 0) : 0;
  const fs::path script = f.job.is_object() ? fs::path(f.job.value("script", "")) : fs::path();

  // Every shard of each split the folder has seen (a shard that never started has no entry).
  std::set<int> splits;
  for (const auto& [key, entry] : f.shards.items())
    if (const auto s = parse_shard_key(key)) splits.insert(s->second);
  if (job_shards > 0) splits.insert(job_shards);
  std::set<std::pair<int, int>> keys;  // (N, I)
  for (const int n : splits)
    for (int i = 0; i < n && static_cast<std::size_t>(i) < std::max<std::size_t>(f.points, 1); ++i)
      keys.insert({n, i});

  RunView r;
  for (const auto& [n, i] : keys) {
    ShardView v;
    v.index = i;
    v.count = n;
    for (std::size_t p = static_cast<std::size_t>(i); p < f.points;
         p += static_cast<std::size_t>(n)) {
      ++v.points_total;
      const auto it = f.runs_of.find(p);
      const std::size_t runs = it == f.runs_of.end() ? 0 : it->second;
      v.runs_done += runs;
      v.points_done += runs == static_cast<std::size_t>(f.repetitions) ? 1 : 0;
    }
    v.runs_total = v.points_total * static_cast<std::size_t>(f.repetitions);
    const std::string key = std::to_string(i) + "/" + std::to_string(n);
    const json* entry = f.shards.contains(key) ? &f.shards[key] : nullptr;
    judge(v, entry, queue, dir, script, n == job_shards && !script.empty());
    r.shards.push_back(v);
  }

  for (const auto& [p, runs] : f.runs_of) {
    r.runs_done += runs;
    r.points_done += runs == static_cast<std::size_t>(f.repetitions) ? 1 : 0;
  }
  r.runs_total = f.points * static_cast<std::size_t>(f.repetitions);
  r.live = std::any_of(r.shards.begin(), r.shards.end(), [](const auto& v) { return v.live; });
  r.complete = f.points > 0 && r.runs_done == r.runs_total;
  return r;
}

// A tune's folder (rosguard tune): its tune.json (once the search finished) or its probes/
// (from the start).
bool is_tune_folder(const fs::path& dir) {
  std::error_code ec;
  return fs::is_regular_file(dir / "tune.json", ec) || fs::is_directory(dir / "probes", ec);
}

// One batch of a tune: one `rosguard run` of a generated scenario (NAME.json, written before
// the run starts) into the results folder NAME/.
struct Batch {
  std::string name;
  fs::path dir;
  bool started = false;  // the folder has its manifest
  Folder folder;
  RunView view;
  std::string state;
};

// The batches in the order tune runs them: probes/unregulated, probes/step-NN, then those of
// --confirm hw (confirm-hw, confirm-hw-unregulated beside probes/).
std::vector<Batch> tune_batches(const fs::path& dir, Queue& queue) {
  std::vector<std::pair<std::string, fs::path>> found;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir / "probes", ec))
    if (e.path().extension() == ".json")
      found.emplace_back(e.path().stem().string(), e.path().parent_path() / e.path().stem());
  std::sort(found.begin(), found.end(), [](const auto& a, const auto& b) {
    return std::make_pair(a.first != "unregulated", a.first) <
           std::make_pair(b.first != "unregulated", b.first);
  });
  for (const char* name : {"confirm-hw", "confirm-hw-unregulated"})
    if (fs::is_regular_file(dir / (std::string(name) + ".json"), ec))
      found.emplace_back(name, dir / name);
  std::vector<Batch> batches;
  for (const auto& [name, folder] : found) {
    Batch b;
    b.name = name;
    b.dir = folder;
    b.started = fs::is_regular_file(folder / "manifest.json", ec);
    if (b.started) {
      b.folder = read_folder(folder);
      b.view = assess(folder, b.folder, queue);
      b.state = b.view.complete             ? "complete"
                : b.view.shards.size() == 1 ? b.view.shards.front().state
                : b.view.live               ? "running"
                                            : "incomplete";
    } else {
      b.state = "not started";
    }
    batches.push_back(std::move(b));
  }
  return batches;
}

std::string slowdowns(const json& setting) {
  const auto num = [&](const char* k) {
    const json& v = setting.value(k, json());
    if (!v.is_number()) return std::string("n/a");
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.4f", v.get<double>());
    return std::string(buf);
  };
  return "RT slowdown " + num("rt_slowdown") + " (worst), nRT slowdown " + num("nrt_slowdown") +
         " (mean)";
}

// The tune's own command, as each batch's manifest records it ("... (step-00)"), or "".
std::string tune_command(const std::vector<Batch>& batches) {
  for (const auto& b : batches)
    if (b.started && !b.folder.command.empty()) {
      std::string command = b.folder.command;
      const std::string suffix = " (" + b.name + ")";
      if (command.size() > suffix.size() &&
          command.compare(command.size() - suffix.size(), suffix.size(), suffix) == 0)
        command.erase(command.size() - suffix.size());
      return command;
    }
  return "";
}

// The tune's state: finished (tune.json), a batch runs, or the tune's process (the last
// started batch's manifest entry names it) is between batches, or gone (`stopped`).
struct TuneState {
  std::string state;
  bool stopped = false;
};

TuneState tune_state(const std::vector<Batch>& batches, bool finished, Queue& queue) {
  const Batch* judged = nullptr;
  const Batch* running = nullptr;
  for (const auto& b : batches) {
    if (b.started && b.folder.shards.contains("0/1")) judged = &b;
    if (b.view.live) running = &b;
  }
  TuneState t{"finished", false};
  if (running) {
    t.state = "running: " + running->name;
  } else if (!finished && judged) {
    ShardView v;
    judge_running(v, judged->folder.shards["0/1"], queue, judged->dir);
    t.stopped = !v.live;
    if (v.live)
      t.state = v.state + (judged == &batches.back() ? ", between batches"
                                                     : ", starting " + batches.back().name);
    else if (judged->state == "complete")  // v.state: "stopped: its process (pid N) is gone ..."
      t.state = "stopped after " + judged->name + v.state.substr(std::string("stopped").size());
    else
      t.state = "stopped after " + judged->name + ": " + judged->state;
  } else if (!finished) {
    t.state = "no batch has run yet (starting, or stopped before its first batch)";
  }
  return t;
}

// `rosguard status --json` of a tune's folder: what tune_status prints, as one object.
json tune_status_json(const fs::path& dir, const std::vector<Batch>& batches,
                      const std::string& command, const TuneState& t, const json& tune,
                      const Queue& queue) {
  json j = {{"kind", "tune"},           {"folder", dir.string()},   {"command", command},
            {"batches", json::array()}, {"points_done", 0},         {"points", 0},
            {"runs_done", 0},           {"runs_total", 0},          {"state", t.state},
            {"stopped", t.stopped},     {"finished", !tune.empty()}};
  for (const auto& b : batches) {
    j["batches"].push_back({{"name", b.name},
                            {"started", b.started},
                            {"points_done", b.view.points_done},
                            {"points", b.folder.points},
                            {"runs_done", b.view.runs_done},
                            {"runs_total", b.view.runs_total},
                            {"state", b.state}});
    j["points_done"] = j["points_done"].get<std::size_t>() + b.view.points_done;
    j["points"] = j["points"].get<std::size_t>() + b.folder.points;
    j["runs_done"] = j["runs_done"].get<std::size_t>() + b.view.runs_done;
    j["runs_total"] = j["runs_total"].get<std::size_t>() + b.view.runs_total;
  }
  // Once finished: tune.json's bound and choice (null where it has none).
  for (const char* key : {"rt_slowdown_max", "best", "closest", "runner_up", "unregulated"})
    j[key] = tune.value(key, json());
  j["slurm_queue_error"] = queue.failed() ? json(queue.why()) : json();
  return j;
}

// `rosguard status` of a tune's folder: what it searches, each batch's progress and state,
// whether the tune runs, stopped or finished, and its choice once finished.
int tune_status(const fs::path& dir, bool as_json) {
  Queue queue;
  const std::vector<Batch> batches = tune_batches(dir, queue);
  std::error_code ec;
  const bool finished = fs::is_regular_file(dir / "tune.json", ec);
  const json tune = finished ? read_json_or_throw(dir / "tune.json", dir) : json::object();
  const std::string command = tune_command(batches);
  const TuneState t = tune_state(batches, finished, queue);
  if (as_json) {
    std::cout << tune_status_json(dir, batches, command, t, tune, queue).dump(2) << "\n";
    return 0;
  }

  std::cout << dir.string() << ": rosguard tune, " << batches.size() << " batch(es)\n";
  if (!command.empty()) std::cout << "  command      " << command << "\n";
  if (finished)
    std::cout << "  searched     " << tune.value("configurations", json::array()).size()
              << " configuration(s) x " << tune.value("ladder_pct", json::array()).size()
              << " threshold(s) x "
              << std::max<std::size_t>(1, tune.value("cases", json::array()).size())
              << " case(s): " << tune.value("simulated_points", 0)
              << " point(s) simulated of the full grid's " << tune.value("grid_points", 0) << "\n";

  std::printf("  %-24s %-13s %-13s %s\n", "batch", "points", "runs", "state");
  std::size_t points_done = 0, points = 0, runs_done = 0, runs = 0;
  for (const auto& b : batches) {
    const std::string p = b.started ? fraction(b.view.points_done, b.folder.points) : "-";
    const std::string r = b.started ? fraction(b.view.runs_done, b.view.runs_total) : "-";
    std::printf("  %-24s %-13s %-13s %s\n", b.name.c_str(), p.c_str(), r.c_str(), b.state.c_str());
    points_done += b.view.points_done;
    points += b.folder.points;
    runs_done += b.view.runs_done;
    runs += b.view.runs_total;
  }

  std::printf("  %-24s %-13s %-13s %s\n", "all", fraction(points_done, points).c_str(),
              fraction(runs_done, runs).c_str(), t.state.c_str());
  if (queue.failed()) std::cout << "note: Slurm's queue could not be read: " << queue.why() << "\n";

  if (finished) {
    const auto line = [](const char* what, const json& setting) {
      std::cout << "  " << std::left << std::setw(13) << what << setting.value("label", "?")
                << "\n  " << std::setw(13) << "" << slowdowns(setting) << "\n";
    };
    std::cout << "  bound        every RT node's slowdown <= "
              << tune.value("rt_slowdown_max", json()).dump() << "\n";
    const json& best = tune.value("best", json());
    if (best.is_object()) {
      line("best", best);
    } else {
      std::cout << "  best         none: no simulated setting meets the bound\n";
      if (tune.value("closest", json()).is_object()) line("closest", tune["closest"]);
    }
    if (tune.value("runner_up", json()).is_object()) line("runner-up", tune["runner_up"]);
    if (tune.value("unregulated", json()).is_object())
      std::cout << "  " << std::left << std::setw(13) << "unregulated"
                << slowdowns(tune["unregulated"]) << "\n";
    std::cout << "  results      " << (dir / "tune.json").string() << ", "
              << (dir / "points.csv").string() << " (rosguard plot " << dir.string() << ")\n";
  }
  if (t.stopped)
    std::cout << "A tune does not resume: run it again with --overwrite"
              << (command.empty() ? std::string(".") : ":\n  " + command + " --overwrite") << "\n";
  return 0;
}
// `rosguard run ... [--backend B] --shard INDEX/COUNT --resume` of a shard of the run in `dir`,
// on the backend the run used (which --backend may have chosen over the scenario's own).
std::string rerun_command(const fs::path& dir, const Folder& f, int index, int count) {
  return "rosguard run " +
         (f.scenario_file.empty() ? std::string("SCENARIO.json") : shell_quote(f.scenario_file)) +
         (f.backend.empty() ? std::string() : " --backend " + shell_quote(f.backend)) + " --out " +
         shell_quote(dir.string()) + " --shard " + std::to_string(index) + "/" +
         std::to_string(count) + " --resume";
}

std::string run_state(const RunView& r) {
  return r.complete ? "complete" : r.live ? "running" : "incomplete";
}

// `rosguard status --json` of a run's folder: what results_status prints, as one object; every
// shard listed, and each shard to run again with its command.
json run_status_json(const fs::path& dir, const Folder& f, const RunView& r, const Queue& queue) {
  json j = {{"kind", "run"},
            {"folder", dir.string()},
            {"scenario_file", f.scenario_file},
            {"points", f.points},
            {"repetitions", f.repetitions},
            {"shards", json::array()},
            {"points_done", r.points_done},
            {"runs_done", r.runs_done},
            {"runs_total", r.runs_total},
            {"state", run_state(r)},
            {"rerun", json::array()},
            {"slurm_queue_error", queue.failed() ? json(queue.why()) : json()}};
  for (const auto& v : r.shards) {
    const std::string key = std::to_string(v.index) + "/" + std::to_string(v.count);
    j["shards"].push_back({{"shard", key},
                           {"points_done", v.points_done},
                           {"points_total", v.points_total},
                           {"runs_done", v.runs_done},
                           {"runs_total", v.runs_total},
                           {"state", v.state},
                           {"live", v.live}});
    if (!v.live && v.runs_done < v.runs_total)
      j["rerun"].push_back({{"shard", key}, {"command", rerun_command(dir, f, v.index, v.count)}});
  }
  return j;
}

}  // namespace

int results_status(const fs::path& dir, bool as_json) {
  if (is_tune_folder(dir)) return tune_status(dir, as_json);
  const Folder f = read_folder(dir);
  const int job_shards = f.job.is_object() ? f.job.value("shards", 0) : 0;
  const fs::path script = f.job.is_object() ? fs::path(f.job.value("script", "")) : fs::path();
  Queue queue;
  const RunView r = assess(dir, f, queue);
  if (as_json) {
    std::cout << run_status_json(dir, f, r, queue).dump(2) << "\n";
    return 0;
  }
  const std::vector<ShardView>& views = r.shards;

  std::cout << dir.string() << ": " << (f.scenario_file.empty() ? "" : f.scenario_file + ", ")
            << f.points << " point(s) x " << f.repetitions << " repetition(s)\n";
  // Many shards: the complete ones are only counted.
  constexpr std::size_t kListedShards = 64;
  const bool all_listed = views.size() <= kListedShards;
  std::size_t unlisted = 0;
  if (!views.empty()) {
    std::printf("  %-9s %-13s %-13s %s\n", "shard", "points", "runs", "state");
    for (const auto& v : views) {
      if (!all_listed && v.state == "complete" && v.runs_done == v.runs_total) {
        ++unlisted;
        continue;
      }
      const std::string key = std::to_string(v.index) + "/" + std::to_string(v.count);
      std::printf("  %-9s %-13s %-13s %s\n", key.c_str(),
                  fraction(v.points_done, v.points_total).c_str(),
                  fraction(v.runs_done, v.runs_total).c_str(), v.state.c_str());
    }
  }
  if (unlisted > 0) std::printf("  (%zu complete shard(s) not listed)\n", unlisted);
  std::printf("  %-9s %-13s %-13s %s\n", "all", fraction(r.points_done, f.points).c_str(),
              fraction(r.runs_done, r.runs_total).c_str(), run_state(r).c_str());
  std::cout.flush();
  if (queue.failed()) std::cout << "note: Slurm's queue could not be read: " << queue.why() << "\n";

  // The shards to run again: not running or queued, runs missing.
  std::map<int, std::vector<int>> rerun;  // N -> I...
  for (const auto& v : views)
    if (!v.live && v.runs_done < v.runs_total) rerun[v.count].push_back(v.index);
  if (rerun.empty()) return 0;
  std::cout << "Re-run the shards that did not finish (--resume: the runs already in points.csv "
               "are skipped, none is written twice):\n";
  std::error_code ec;
  for (const auto& [n, list] : rerun) {
    if (n == job_shards && fs::exists(script, ec)) {
      std::string array;
      for (const int i : list)
        array += (array.empty() ? "" : ",") + std::to_string(i);
      std::cout << "  on Slurm: sbatch --array=" << array << " " << shell_quote(script.string())
                << "\n";
    }
    constexpr std::size_t kShown = 4;
    for (std::size_t k = 0; k < list.size() && k < kShown; ++k)
      std::cout << "  here:     " << rerun_command(dir, f, list[k], n) << "\n";
    if (list.size() > kShown)
      std::cout << "  (and " << list.size() - kShown << " more shard(s) of " << n
                << " the same way)\n";
  }
  return 0;
}

}  // namespace rosguard

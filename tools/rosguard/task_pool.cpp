#include "task_pool.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <iostream>
#include <optional>

#include "core/error.h"
#include "results_store.h"
#include "stop_signal.h"
#include "trace_writer.h"

namespace rosguard {
using json = nlohmann::json;

namespace {

// ---------------------------------------------------------------------------------------------
// Worker protocol: a TaskResult as JSON. A number that was not measured (NaN) travels as null.

json to_json(const TaskResult& r) {
  json j;
  j["ok"] = r.ok;
  j["interrupted"] = r.interrupted;
  j["error"] = r.error;
  j["iso"] = {r.iso.time_us, r.iso.ipc, r.iso.mbps};
  json rt = json::array(), nrt = json::array(), samples = json::array();
  for (const auto& n : r.outcome.rt)
    rt.push_back({n.name, n.time_us, n.jobs, n.response_us, n.deadline_misses});
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
  r.error = j.at("error");
  const json& iso = j.at("iso");
  r.iso = {number_or_nan(iso.at(0)), number_or_nan(iso.at(1)), number_or_nan(iso.at(2))};
  for (const auto& n : j.at("rt"))
    r.outcome.rt.push_back(
        {n.at(0), number_or_nan(n.at(1)), n.at(2), n.at(3).get<std::vector<double>>(), n.at(4)});
  for (const auto& n : j.at("nrt"))
    r.outcome.nrt.push_back({n.at(0), number_or_nan(n.at(1)), number_or_nan(n.at(2)), n.at(3),
                             number_or_nan(n.at(4)), number_or_nan(n.at(5))});
  for (const auto& s : j.at("samples"))
    r.outcome.samples.push_back({s.at(0), number_or_nan(s.at(1))});
  r.fallbacks = j.at("fallbacks").get<std::vector<std::pair<std::string, std::string>>>();
  r.facts = j.at("facts").get<std::map<std::string, std::string>>();
  r.trace = j.at("trace");
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
  bool stop_requested() const override { return stop_signal() != 0; }

 private:
  TaskResult& result_;
  ChromeTrace* trace_;
};

// ---------------------------------------------------------------------------------------------
// Executors.

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

void waitpid_retrying(pid_t pid, int& status) {
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
}

// In the forked worker: default signal handling (a terminal's Ctrl-C reaches the whole process
// group), run the task, send the result, leave without running the parent's destructors.
[[noreturn]] void worker_main(int result_fd, const Task& task, const RunState& st) {
  ::signal(SIGINT, SIG_DFL);
  ::signal(SIGTERM, SIG_DFL);
  std::string payload;
  try {
    payload = to_json(execute(task, st)).dump();
  } catch (const std::exception& e) {
    TaskResult r;
    r.error = e.what();
    payload = to_json(r).dump();
  }
  const char* p = payload.data();
  std::size_t left = payload.size();
  while (left > 0) {
    const ssize_t n = ::write(result_fd, p, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) ::_exit(3);
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  ::_exit(0);
}

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
      ::close(fds[0]);
      worker_main(fds[1], task, st_);
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
      waitpid_retrying(w.pid, status);
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
    waitpid_retrying(w.pid, status);
    TaskResult r;
    if (WIFSIGNALED(status)) {
      const int sig = WTERMSIG(status);
      r.interrupted = stop_signal() != 0 && (sig == SIGINT || sig == SIGTERM);
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

}  // namespace

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
                                    task_seed(lp.scenario.seed, task.iso_key, task.rep), ctx);
    } else {
      r.outcome = st.backend->run_point(lp.scenario, st.baselines, task.rep,
                                        task_seed(lp.scenario.seed, lp.sweep.id, task.rep), ctx);
      if (st.trace) r.trace = trace.take(point_label(lp.sweep, task.rep));
    }
    r.ok = true;
  } catch (const Interrupted&) {
    r.interrupted = true;
    r.error = "interrupted";
  } catch (const std::exception& e) {
    r.error = e.what();
  }
  return r;
}

std::unique_ptr<Executor> make_executor(const RunState& st, bool process_per_task, int jobs) {
  if (process_per_task) return std::make_unique<ForkExecutor>(st, std::max(1, jobs));
  return std::make_unique<InProcessExecutor>(st);
}

}  // namespace rosguard

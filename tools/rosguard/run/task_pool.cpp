#include "run/task_pool.h"

#include <fcntl.h>
#include <malloc.h>
#include <poll.h>
#include <signal.h>
#include <sys/epoll.h>
#include <sys/prctl.h>
#include <sys/signalfd.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <deque>
#include <iostream>
#include <optional>
#include <set>
#include <string_view>
#include <type_traits>

#include "core/error.h"
#include "results/results.h"
#include "run/stop_signal.h"
#include "run/unregulated.h"
#include "store/results_store.h"
#include "store/trace_writer.h"

namespace rosguard {
using json = nlohmann::json;

namespace {

// ---------------------------------------------------------------------------------------------
// Worker protocol: a TaskResult in a compact binary form (numbers as their bytes, so a double
// comes back exactly, NaN included; strings and lists with their length first). A point's
// samples.csv lines (some 16 KB) and points.csv row, when the worker made them, travel as they
// are: the runner, which reads every result of a sweep one after another, neither parses nor
// rewrites them (JSON here took a quarter of its time per result).

class Encoder {
 public:
  template <typename T>
  void number(T v) {
    static_assert(std::is_arithmetic_v<T>);
    out_.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  void text(const std::string& v) {
    number<std::uint64_t>(v.size());
    out_ += v;
  }
  std::string take() { return std::move(out_); }

 private:
  std::string out_;
};

// Reads what an Encoder wrote; throws std::out_of_range when `bytes` ends too soon.
class Decoder {
 public:
  explicit Decoder(std::string_view bytes) : in_(bytes) {}
  template <typename T>
  T number() {
    T v;
    std::memcpy(&v, take(sizeof v).data(), sizeof v);
    return v;
  }
  std::string text() { return std::string(take(count())); }
  // A count of items or bytes that cannot exceed what is left (a corrupt count fails here).
  std::size_t count() {
    const auto n = number<std::uint64_t>();
    if (n > in_.size()) throw std::out_of_range("a count beyond the end of the result");
    return static_cast<std::size_t>(n);
  }
  bool done() const { return in_.empty(); }

 private:
  std::string_view take(std::size_t n) {
    if (n > in_.size()) throw std::out_of_range("the result is cut short");
    const std::string_view v = in_.substr(0, n);
    in_.remove_prefix(n);
    return v;
  }
  std::string_view in_;
};

std::string encode(const TaskResult& r) {
  Encoder e;
  e.number<std::uint8_t>(r.ok);
  e.number<std::uint8_t>(r.interrupted);
  e.text(r.error);
  for (const double v : {r.iso.time_us, r.iso.ipc, r.iso.mbps})
    e.number(v);
  e.number<std::uint64_t>(r.outcome.rt.size());
  for (const auto& n : r.outcome.rt) {
    e.text(n.name);
    e.number(n.time_us);
    e.number<std::int64_t>(n.jobs);
    e.number<std::uint64_t>(n.response_us.size());
    for (const double v : n.response_us)
      e.number(v);
    e.number<std::int64_t>(n.deadline_misses);
  }
  e.number<std::uint64_t>(r.outcome.nrt.size());
  for (const auto& n : r.outcome.nrt) {
    e.text(n.name);
    for (const double v : {n.time_us, n.bandwidth_mbps})
      e.number(v);
    e.number(n.throttle_count);
    for (const double v : {n.throttled_us, n.runs})
      e.number(v);
  }
  e.number<std::uint64_t>(r.outcome.samples.size());
  for (const auto& o : r.outcome.samples) {
    e.text(o.kind);
    e.number(o.value_us);
  }
  e.number<std::uint64_t>(r.fallbacks.size());
  for (const auto& [what, detail] : r.fallbacks) {
    e.text(what);
    e.text(detail);
  }
  e.number<std::uint64_t>(r.facts.size());
  for (const auto& [k, v] : r.facts) {
    e.text(k);
    e.text(v);
  }
  e.text(r.trace.empty() ? std::string() : r.trace.dump());
  e.number<std::uint8_t>(r.rows_made);
  if (r.rows_made) {
    e.text(r.samples_csv);
    e.text(r.row_csv);
  }
  return e.take();
}

// What encode() wrote; throws (std::out_of_range, or json's error for a bad trace) when `bytes`
// is not all of it.
TaskResult decode(const std::string& bytes) {
  Decoder d(bytes);
  TaskResult r;
  r.ok = d.number<std::uint8_t>() != 0;
  r.interrupted = d.number<std::uint8_t>() != 0;
  r.error = d.text();
  r.iso.time_us = d.number<double>();
  r.iso.ipc = d.number<double>();
  r.iso.mbps = d.number<double>();
  for (std::size_t i = 0, n = d.count(); i < n; ++i) {
    RtOutcome o;
    o.name = d.text();
    o.time_us = d.number<double>();
    o.jobs = static_cast<int>(d.number<std::int64_t>());
    for (std::size_t k = 0, m = d.count(); k < m; ++k)
      o.response_us.push_back(d.number<double>());
    o.deadline_misses = static_cast<int>(d.number<std::int64_t>());
    r.outcome.rt.push_back(std::move(o));
  }
  for (std::size_t i = 0, n = d.count(); i < n; ++i) {
    NrtOutcome o;
    o.name = d.text();
    o.time_us = d.number<double>();
    o.bandwidth_mbps = d.number<double>();
    o.throttle_count = d.number<std::uint64_t>();
    o.throttled_us = d.number<double>();
    o.runs = d.number<double>();
    r.outcome.nrt.push_back(std::move(o));
  }
  for (std::size_t i = 0, n = d.count(); i < n; ++i) {
    Observation o;
    o.kind = d.text();
    o.value_us = d.number<double>();
    r.outcome.samples.push_back(std::move(o));
  }
  for (std::size_t i = 0, n = d.count(); i < n; ++i) {
    std::string what = d.text();
    r.fallbacks.emplace_back(std::move(what), d.text());
  }
  for (std::size_t i = 0, n = d.count(); i < n; ++i) {
    std::string k = d.text();
    r.facts[std::move(k)] = d.text();
  }
  if (const std::string trace = d.text(); !trace.empty()) r.trace = json::parse(trace);
  r.rows_made = d.number<std::uint8_t>() != 0;
  if (r.rows_made) {
    r.samples_csv = d.text();
    r.row_csv = d.text();
  }
  if (!d.done()) throw std::out_of_range("bytes after the end of the result");
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

[[noreturn]] void fail_errno(const char* what) {
  throw RunError(std::string(what) + ": " + std::strerror(errno));
}

// ---------------------------------------------------------------------------------------------
// Task host protocol: frames on a Unix stream socket, a Frame then `size` bytes of payload.
//   runner -> host: Task (payload: encode_task; the pipe's write end as SCM_RIGHTS),
//                   Baselines (payload: {"baselines": baselines_to_json, "coruns":
//                   UnregulatedCoruns::to_json}), Header (payload: points.csv's columns, as a
//                   JSON list), Stop (SIGTERM to every worker).
//   host -> runner: Exit (`value`: the worker's wait status), Failed (payload: why the host
//                   could not start it; its pipe is closed).
// `seq` numbers the runner's tasks (never reused within a run).

struct Frame {
  enum Type : std::uint32_t { Task = 1, Baselines, Header, Stop, Exit, Failed } type;
  std::uint32_t size;
  std::uint64_t seq;
  std::int64_t value;
};

// Sends a frame (and `fd` with its first byte when >= 0). Returns false when the peer is gone.
bool send_frame(int sock, Frame f, const std::string& payload = "", int fd = -1) {
  f.size = static_cast<std::uint32_t>(payload.size());
  std::string bytes(reinterpret_cast<const char*>(&f), sizeof f);
  bytes += payload;
  std::size_t sent = 0;
  while (sent < bytes.size()) {
    iovec iov{bytes.data() + sent, bytes.size() - sent};
    msghdr msg{};
    msg.msg_iov = &iov;
    msg.msg_iovlen = 1;
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(int))] = {};
    if (fd >= 0 && sent == 0) {
      msg.msg_control = control;
      msg.msg_controllen = sizeof control;
      cmsghdr* c = CMSG_FIRSTHDR(&msg);
      c->cmsg_level = SOL_SOCKET;
      c->cmsg_type = SCM_RIGHTS;
      c->cmsg_len = CMSG_LEN(sizeof(int));
      std::memcpy(CMSG_DATA(c), &fd, sizeof(int));
    }
    const ssize_t n = ::sendmsg(sock, &msg, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    sent += static_cast<std::size_t>(n);
  }
  return true;
}

// The receiving side: bytes and passed descriptors, in order.
class FrameReader {
 public:
  explicit FrameReader(int sock) : sock_(sock) {}
  ~FrameReader() {
    for (int fd : fds_)
      ::close(fd);
  }
  FrameReader(const FrameReader&) = delete;
  FrameReader& operator=(const FrameReader&) = delete;

  // One recvmsg. Returns false at EOF or on an error other than EINTR / EAGAIN.
  bool receive() {
    char buf[65536];
    iovec iov{buf, sizeof buf};
    alignas(cmsghdr) char control[CMSG_SPACE(16 * sizeof(int))];
    msghdr msg{};
    msg.msg_iov = &iov;
    msg.msg_iovlen = 1;
    msg.msg_control = control;
    msg.msg_controllen = sizeof control;
    const ssize_t n = ::recvmsg(sock_, &msg, MSG_CMSG_CLOEXEC | MSG_DONTWAIT);
    if (n < 0) return errno == EINTR || errno == EAGAIN;
    for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c; c = CMSG_NXTHDR(&msg, c)) {
      if (c->cmsg_level != SOL_SOCKET || c->cmsg_type != SCM_RIGHTS) continue;
      const std::size_t count = (c->cmsg_len - CMSG_LEN(0)) / sizeof(int);
      for (std::size_t i = 0; i < count; ++i) {
        int fd = -1;
        std::memcpy(&fd, CMSG_DATA(c) + i * sizeof(int), sizeof(int));
        fds_.push_back(fd);
      }
    }
    if (n == 0) return false;
    data_.append(buf, static_cast<std::size_t>(n));
    return true;
  }

  // The next whole frame, if one has arrived.
  std::optional<std::pair<Frame, std::string>> next() {
    if (data_.size() - pos_ < sizeof(Frame)) return std::nullopt;
    Frame f{};
    std::memcpy(&f, data_.data() + pos_, sizeof f);
    if (data_.size() - pos_ - sizeof f < f.size) return std::nullopt;
    std::string payload = data_.substr(pos_ + sizeof f, f.size);
    pos_ += sizeof f + f.size;
    if (pos_ == data_.size()) {
      data_.clear();
      pos_ = 0;
    }
    return std::make_pair(f, std::move(payload));
  }

  // The oldest descriptor received and not taken yet (a Task frame's pipe; it arrives with the
  // frame's first byte, so never after the frame), or -1.
  int take_fd() {
    if (fds_.empty()) return -1;
    const int fd = fds_.front();
    fds_.pop_front();
    return fd;
  }
  const std::deque<int>& fds() const { return fds_; }

 private:
  int sock_;
  std::string data_;
  std::size_t pos_ = 0;
  std::deque<int> fds_;
};

// A task as the host reads it (decode_task), with its point's sweep index.
std::string encode_task(const Task& t, std::size_t point) {
  Encoder e;
  e.number<std::uint8_t>(t.kind == Task::Kind::Isolation);
  e.number<std::uint64_t>(point);
  e.number<std::int64_t>(t.rep);
  e.text(t.iso_key);
  e.number<std::int64_t>(t.core);
  e.number<std::uint8_t>(t.corun);
  return e.take();
}

Task decode_task(const std::string& bytes) {
  Decoder d(bytes);
  Task t;
  t.kind = d.number<std::uint8_t>() != 0 ? Task::Kind::Isolation : Task::Kind::Point;
  t.point = d.number<std::uint64_t>();
  t.rep = static_cast<int>(d.number<std::int64_t>());
  t.iso_key = d.text();
  t.core = static_cast<int>(d.number<std::int64_t>());
  t.corun = d.number<std::uint8_t>() != 0;
  if (!d.done()) throw std::out_of_range("bytes after the end of the task");
  return t;
}

// Writes all of `payload` to `fd`; false on an error.
bool write_all(int fd, const std::string& payload) {
  const char* p = payload.data();
  std::size_t left = payload.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  return true;
}

// In a worker (forked by the host): default signal handling back, nothing of the host's kept
// open but its own pipe, run the task, send the result, leave without destructors.
[[noreturn]] void worker_main(int result_fd, const Task& task, const TaskInputs& inputs,
                              const TaskFunction& run, pid_t host) {
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (::getppid() != host) ::_exit(4);
  ::prctl(PR_SET_NAME, "rosguard-task");
  for (int sig : {SIGINT, SIGTERM, SIGPIPE, SIGCHLD})
    ::signal(sig, SIG_DFL);
  sigset_t none;
  sigemptyset(&none);
  ::sigprocmask(SIG_SETMASK, &none, nullptr);
  std::string payload;
  try {
    payload = encode(run(task, inputs));
  } catch (const std::exception& e) {
    TaskResult r;
    r.error = e.what();
    payload = encode(r);
  }
  ::_exit(write_all(result_fd, payload) ? 0 : 3);
}

// The host's loop: tasks in from the runner's socket, a forked worker each (at most `limit` at
// once), each worker's end reported back as an Exit frame.
class HostLoop {
 public:
  HostLoop(int sock, int sfd, const TaskFunction& run)
      : sock_(sock), sfd_(sfd), run_(run), self_(::getpid()), reader_(sock) {}

  // Serves tasks until the runner closes the socket (or is gone), then stops what still runs
  // and reaps it.
  void serve() {
    while (open_) {
      pollfd pfds[2] = {{sock_, POLLIN, 0}, {sfd_, POLLIN, 0}};
      if (::poll(pfds, 2, -1) < 0) {
        if (errno == EINTR) continue;
        break;
      }
      if (pfds[1].revents) {
        signalfd_siginfo info;
        while (::read(sfd_, &info, sizeof info) > 0) {
        }
        reap(false);
        start_queued();
      }
      if (!pfds[0].revents) continue;
      open_ = reader_.receive();
      while (auto frame = reader_.next())
        handle(frame->first, frame->second);
      start_queued();
    }
    stop_workers();
    open_ = false;
    reap(true);
  }

 private:
  // Tasks wait here while `limit_` workers run (the runner keeps a few more in flight than it
  // has workers, so that a worker that ends is followed at once, without a round trip through
  // the runner); they start in the order they came.
  struct Queued {
    Task task;
    int fd;
    std::uint64_t seq;
  };

  void reap(bool block) {
    while (!workers_.empty()) {
      int status = 0;
      const pid_t pid = ::waitpid(-1, &status, block ? 0 : WNOHANG);
      if (pid < 0 && errno == EINTR) continue;
      if (pid <= 0) return;
      const auto it = workers_.find(pid);
      if (it == workers_.end()) continue;
      if (open_) open_ = send_frame(sock_, {Frame::Exit, 0, it->second, status});
      workers_.erase(it);
    }
  }

  void stop_workers() {
    for (const auto& w : workers_)
      ::kill(w.first, SIGTERM);
  }

  void start_queued() {
    while (open_ && !queued_.empty() && workers_.size() < limit_) {
      Queued q = std::move(queued_.front());
      queued_.pop_front();
      const pid_t pid = ::fork();
      if (pid == 0) {
        ::close(sock_);
        ::close(sfd_);
        for (int other : reader_.fds())
          ::close(other);
        for (const auto& other : queued_)  // other tasks' pipes: their EOF must not wait on this
          ::close(other.fd);
        worker_main(q.fd, q.task, inputs_, run_, self_);
      }
      ::close(q.fd);
      if (pid > 0)
        workers_[pid] = q.seq;
      else
        open_ = send_frame(sock_, {Frame::Failed, 0, q.seq, 0},
                           std::string("fork: ") + std::strerror(errno));
    }
  }

  void handle(const Frame& f, const std::string& payload) {
    if (f.type == Frame::Stop) {
      stop_workers();
      for (const auto& q : queued_) {  // never started: no result, the runner is told
        ::close(q.fd);
        if (open_) open_ = send_frame(sock_, {Frame::Failed, 0, q.seq, 0}, "stopped before it ran");
      }
      queued_.clear();
    } else if (f.type == Frame::Baselines || f.type == Frame::Header) {
      if (f.type == Frame::Header)
        limit_ = static_cast<std::size_t>(std::max<std::int64_t>(1, f.value));
      try {
        const json doc = json::parse(payload);
        if (f.type == Frame::Baselines) {
          inputs_.baselines = baselines_from_json(doc.at("baselines"));
          inputs_.coruns = UnregulatedCoruns::from_json(doc.at("coruns"));
        } else {
          inputs_.header = doc.get<std::vector<std::string>>();
        }
      } catch (const std::exception&) {
        ::_exit(6);  // the runner sees the socket close
      }
    } else if (f.type == Frame::Task) {
      queue_task(f.seq, payload);
    }
  }

  void queue_task(std::uint64_t seq, const std::string& payload) {
    const int fd = reader_.take_fd();
    std::string why;
    Task task;
    try {
      task = decode_task(payload);
    } catch (const std::exception& e) {
      why = std::string("bad task: ") + e.what();
    }
    if (why.empty() && fd < 0) why = "no pipe came with the task";
    if (!why.empty()) {
      if (fd >= 0) ::close(fd);
      open_ = send_frame(sock_, {Frame::Failed, 0, seq, 0}, why);
    } else {
      queued_.push_back({std::move(task), fd, seq});
    }
  }

  const int sock_;
  const int sfd_;
  const TaskFunction& run_;
  const pid_t self_;
  FrameReader reader_;
  TaskInputs inputs_;
  std::map<pid_t, std::uint64_t> workers_;  // pid -> seq
  std::deque<Queued> queued_;
  std::size_t limit_ = 1;  // concurrent workers: the runner's --jobs (Header frame)
  bool open_ = true;
};

// The host's life: serve tasks until the runner closes the socket, then stop the workers.
[[noreturn]] void host_main(int sock, const std::function<void()>& warm_up, const TaskFunction& run,
                            pid_t runner) {
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (::getppid() != runner) ::_exit(0);
  ::prctl(PR_SET_NAME, "rosguard-host");
  ::signal(SIGINT, SIG_IGN);  // the runner decides what a Ctrl-C stops
  ::signal(SIGTERM, SIG_IGN);
  ::signal(SIGPIPE, SIG_IGN);
  sigset_t chld;
  sigemptyset(&chld);
  sigaddset(&chld, SIGCHLD);
  ::sigprocmask(SIG_BLOCK, &chld, nullptr);
  const int sfd = ::signalfd(-1, &chld, SFD_CLOEXEC | SFD_NONBLOCK);
  if (sfd < 0) ::_exit(5);
  try {
    warm_up();
  } catch (...) {  // the runner reports whatever is wrong with the scenario
  }
  // Free heap pages go back to the kernel: every fork copies the page table entries of what
  // stays mapped.
  ::malloc_trim(0);
  HostLoop(sock, sfd, run).serve();
  ::_exit(0);
}

// The runner's side: tasks go to the hosts (to the one with the fewest in flight); results come
// back through each task's pipe.
class HostExecutor : public Executor {
 public:
  HostExecutor(const RunState& st, int jobs, const std::vector<TaskHost*>& hosts)
      : st_(st), epoll_(::epoll_create1(EPOLL_CLOEXEC)) {
    if (epoll_ < 0) fail_errno("epoll_create1");
    // --jobs split among the hosts as evenly as it goes (each host at least one worker).
    const int count = static_cast<int>(hosts.size());
    for (int h = 0; h < count; ++h) {
      links_.emplace_back(*hosts[static_cast<std::size_t>(h)],
                          std::max(1, jobs / count + (h < jobs % count ? 1 : 0)));
      watch(links_.back().host.socket(), kHostTag | static_cast<std::uint64_t>(h));
    }
  }
  ~HostExecutor() override {
    stop_all();
    ::close(epoll_);
  }

  // Each host runs its share of --jobs workers at a time; kQueued more wait there, ready to start.
  bool can_submit() const override {
    return std::any_of(links_.begin(), links_.end(), [](const Link& l) { return l.has_room(); });
  }
  bool busy() const override { return !workers_.empty(); }

  void submit(std::size_t id, const Task& task) override {
    Link* link = nullptr;
    for (auto& l : links_)
      if (l.has_room() && (!link || l.in_flight < link->in_flight)) link = &l;
    if (!link) throw ContractError("HostExecutor::submit: no host has room (see can_submit)");
    if (link->gone) throw RunError(link->exited());
    if (!link->header_sent) {
      if (!send_frame(link->host.socket(), {Frame::Header, 0, 0, link->jobs},
                      json(st_.header).dump()))
        throw RunError(link->lost());
      link->header_sent = true;
    }
    send_baselines(*link);
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0) fail_errno("pipe");
    const std::size_t point = st_.loaded->points.at(task.point).sweep.index;
    const std::uint64_t seq = ++seq_;
    const bool sent =
        send_frame(link->host.socket(), {Frame::Task, 0, seq, 0}, encode_task(task, point), fds[1]);
    ::close(fds[1]);
    if (!sent) {
      ::close(fds[0]);
      throw RunError(link->lost());
    }
    ++link->in_flight;
    workers_.push_back({id, seq, fds[0], {}, false, link});
    watch(fds[0], seq);
  }

  std::pair<std::size_t, TaskResult> wait_one() override {
    while (true) {
      for (std::size_t i = 0; i < workers_.size(); ++i)
        if (auto r = finished(i)) return {workers_erase(i), std::move(*r)};
      poll_once();
    }
  }

  void stop_all() override {
    if (workers_.empty()) return;
    for (auto& l : links_)
      if (!l.gone && !send_frame(l.host.socket(), {Frame::Stop, 0, 0, 0})) l.gone = true;
    // Until every worker has ended (its exit reported), draining the pipes meanwhile; a host
    // that says nothing for 10 s is given up on (its workers die with it: PR_SET_PDEATHSIG).
    int quiet_polls = 0;
    while (quiet_polls < 50 && std::any_of(workers_.begin(), workers_.end(), [&](const Worker& w) {
             return !w.link->gone && !exits_.count(w.seq) && !failures_.count(w.seq);
           })) {
      const int n = poll_once();
      if (n < 0) break;
      quiet_polls = n == 0 ? quiet_polls + 1 : 0;
    }
    for (const auto& w : workers_) {
      close_pipe(w);
      exits_.erase(w.seq);
      failures_.erase(w.seq);
      --w.link->in_flight;
    }
    workers_.clear();
  }

 private:
  // One task host: its socket's frames, its share of the workers, what it was sent.
  struct Link {
    Link(TaskHost& h, int j) : host(h), reader(h.socket()), jobs(j) {}
    TaskHost& host;
    FrameReader reader;
    int jobs;           // workers it runs at a time
    int in_flight = 0;  // tasks sent and not finished
    bool gone = false;  // its socket closed
    bool header_sent = false;
    std::size_t baselines_sent = static_cast<std::size_t>(-1);

    bool has_room() const { return in_flight < jobs + kQueued; }
    // Why it stopped answering: its exit status, when it has one.
    std::string exited() const {
      int status = 0;
      std::string why = "it closed its socket";
      if (::waitpid(host.pid(), &status, WNOHANG) == host.pid())
        why = WIFSIGNALED(status) ? std::string("signal ") + strsignal(WTERMSIG(status))
                                  : "status " + std::to_string(WEXITSTATUS(status));
      return "the task host process exited (" + why + ")";
    }
    std::string lost() {
      gone = true;
      return exited();
    }
  };

  struct Worker {
    std::size_t id;
    std::uint64_t seq;
    int fd;
    std::string data;
    bool eof;
    Link* link;  // the host that runs it
  };

  // Waits (at most 200 ms) for the workers' pipes and the hosts' sockets (each registered with
  // the epoll instance while it can say more: a pipe until its EOF, a socket until its host is
  // gone) and reads what is ready. Returns how many were ready (-1 on an error other than EINTR).
  int poll_once() {
    epoll_event events[64];
    const int n = ::epoll_wait(epoll_, events, 64, 200);
    if (n < 0) return errno == EINTR ? 0 : -1;
    for (int e = 0; e < n; ++e) {
      const std::uint64_t tag = events[e].data.u64;
      if (tag & kHostTag) {
        Link& link = links_[static_cast<std::size_t>(tag & ~kHostTag)];
        if (!link.gone) read_host(link);
        if (link.gone) unwatch(link.host.socket());
        continue;
      }
      const auto w = std::find_if(workers_.begin(), workers_.end(),
                                  [&](const Worker& x) { return x.seq == tag; });
      if (w == workers_.end()) continue;
      read_result(*w);
      if (w->eof) unwatch(w->fd);
    }
    return n;
  }

  void watch(int fd, std::uint64_t tag) {
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.u64 = tag;
    if (::epoll_ctl(epoll_, EPOLL_CTL_ADD, fd, &ev) != 0) fail_errno("epoll_ctl");
  }
  void unwatch(int fd) { ::epoll_ctl(epoll_, EPOLL_CTL_DEL, fd, nullptr); }
  void close_pipe(const Worker& w) {
    if (!w.eof) unwatch(w.fd);
    ::close(w.fd);
  }

  // A host's copy of the baselines and co-runs is brought up to date before a task that may
  // read them.
  void send_baselines(Link& link) {
    std::size_t measurements = st_.coruns.measurements();
    for (const auto& [key, runs] : st_.baselines.all())
      measurements += runs.runs.size() + 1;
    if (measurements == link.baselines_sent) return;
    const json doc = {{"baselines", baselines_to_json(st_.baselines)},
                      {"coruns", st_.coruns.to_json()}};
    if (!send_frame(link.host.socket(), {Frame::Baselines, 0, 0, 0}, doc.dump()))
      throw RunError(link.lost());
    link.baselines_sent = measurements;
  }

  void read_result(Worker& w) {
    char buf[65536];
    const ssize_t got = ::read(w.fd, buf, sizeof buf);
    if (got > 0)
      w.data.append(buf, static_cast<std::size_t>(got));
    else if (got == 0 || errno != EINTR)
      w.eof = true;  // EOF (or a read error): the worker is done
  }

  void read_host(Link& link) {
    if (!link.reader.receive()) link.gone = true;
    while (auto frame = link.reader.next()) {
      const auto& [f, payload] = *frame;
      if (f.type == Frame::Exit) exits_[f.seq] = static_cast<int>(f.value);
      if (f.type == Frame::Failed) failures_[f.seq] = payload;
    }
    // Reports of tasks already finished (from their result alone) are not kept.
    for (auto it = exits_.begin(); it != exits_.end();)
      it = it->first <= finished_below_ && !running(it->first) ? exits_.erase(it) : std::next(it);
  }

  bool running(std::uint64_t seq) const {
    return std::any_of(workers_.begin(), workers_.end(),
                       [&](const Worker& w) { return w.seq == seq; });
  }

  // Worker i's result once it is known: a whole result from its pipe (its exit status is not
  // awaited then), else its exit status or the host's word on why it did not start.
  std::optional<TaskResult> finished(std::size_t i) {
    Worker& w = workers_[i];
    if (const auto f = failures_.find(w.seq); f != failures_.end()) {
      TaskResult r;
      r.error = "the task host could not start a worker: " + f->second;
      failures_.erase(f);
      return r;
    }
    if (!w.eof) return std::nullopt;
    const auto exit = exits_.find(w.seq);
    const bool known = exit != exits_.end();
    const int status = known ? exit->second : 0;
    if (!known || !WIFSIGNALED(status)) {
      try {
        TaskResult r = decode(w.data);
        if (known) exits_.erase(exit);
        return r;
      } catch (const std::exception&) {
        if (!known && !w.link->gone) return std::nullopt;  // its exit status tells more
      }
    }
    if (known) exits_.erase(exit);
    TaskResult r;
    if (!known) {
      r.error = "worker process left no readable result, and " + w.link->exited();
    } else if (WIFSIGNALED(status)) {
      const int sig = WTERMSIG(status);
      r.interrupted = stop_signal() != 0 && (sig == SIGINT || sig == SIGTERM);
      r.error = r.interrupted ? "interrupted"
                              : "worker process died with signal " + std::to_string(sig) + " (" +
                                    strsignal(sig) + ")";
    } else {
      r.error = "worker process exited with status " +
                std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) +
                " and no readable result";
    }
    return r;
  }

  std::size_t workers_erase(std::size_t i) {
    const Worker w = std::move(workers_[i]);
    workers_.erase(workers_.begin() + static_cast<std::ptrdiff_t>(i));
    close_pipe(w);
    --w.link->in_flight;
    finished_below_ = std::max(finished_below_, w.seq);
    return w.id;
  }

  static constexpr int kQueued = 2;
  static constexpr std::uint64_t kHostTag = std::uint64_t{1} << 63;  // else a worker's seq
  const RunState& st_;
  int epoll_;
  std::deque<Link> links_;  // a deque: workers point at their link
  std::vector<Worker> workers_;
  std::uint64_t seq_ = 0;
  std::uint64_t finished_below_ = 0;
  std::map<std::uint64_t, int> exits_;             // seq -> wait status
  std::map<std::uint64_t, std::string> failures_;  // seq -> why it did not start
};

// A point run's points.csv row (with its newline), its unregulated cells filled.
std::string point_row(const std::vector<std::string>& header, const LoadedPoint& lp, int rep,
                      const PointOutcome& outcome, const Baselines& baselines,
                      const UnregulatedCoruns& coruns) {
  std::string row = points_row(header, lp.sweep, lp.scenario, rep, outcome, baselines);
  row.pop_back();  // the newline
  const std::string key =
      UnregulatedCoruns::needed(lp.scenario) ? UnregulatedCoruns::key(lp.scenario) : "";
  return fill_unregulated_cells(header, row, lp.scenario, key, coruns, baselines) + "\n";
}

}  // namespace

std::pair<std::string, std::string> run_rows(const TaskResult& r, const LoadedPoint& lp, int rep,
                                             const RunState& st) {
  if (r.rows_made) return {r.samples_csv, r.row_csv};
  return {samples_rows(lp.sweep.id, rep, r.outcome),
          point_row(st.header, lp, rep, r.outcome, st.baselines, st.coruns)};
}

std::string point_label(const SweepPoint& p, int rep) {
  std::string s = "point " + p.id + " rep " + std::to_string(rep);
  std::string params;
  for (const auto& q : p.params)
    params += (params.empty() ? "" : ", ") + q.path + "=" +
              (q.value.is_string() ? q.value.get<std::string>() : q.value.dump());
  return params.empty() ? s : s + " (" + params + ")";
}

TaskResult execute(const Task& task, const RunState& st) {
  return execute(task, st.loaded->points[task.point], *st.backend, st.baselines, st.trace);
}

TaskResult execute(const Task& task, const LoadedPoint& lp, Backend& backend,
                   const Baselines& baselines, bool trace_on) {
  TaskResult r;
  const int reps = lp.scenario.repetitions;
  ChromeTrace trace(static_cast<int>(lp.sweep.index) * reps + task.rep + 1);
  TaskContext ctx(r, trace_on && task.kind == Task::Kind::Point ? &trace : nullptr);
  try {
    if (task.kind == Task::Kind::Isolation) {
      const WorkloadInfo* workload = task.workload;
      const auto find = [&](const auto& nodes) {
        for (const auto& n : nodes)
          if (!workload && n.core == task.core &&
              Baselines::key(lp.scenario, n.workload, n.core) == task.iso_key)
            workload = &n.workload;
      };
      find(lp.scenario.nodes.rt);
      find(lp.scenario.nodes.nrt);
      if (!workload)
        throw ContractError("isolation baseline " + task.iso_key + " is not one of point " +
                            lp.sweep.id + "'s");
      r.iso = backend.isolation(lp.scenario, *workload, task.core,
                                task_seed(lp.scenario.seed, task.iso_key, task.rep), ctx);
    } else {
      r.outcome = backend.run_point(lp.scenario, baselines, task.rep,
                                    task_seed(lp.scenario.seed, lp.sweep.id, task.rep), ctx);
      if (trace_on) r.trace = trace.take(point_label(lp.sweep, task.rep));
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

TaskHost::TaskHost(std::function<void()> warm_up, TaskFunction run,
                   const std::vector<std::unique_ptr<TaskHost>>& others) {
  int sv[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) != 0) fail_errno("socketpair");
  std::cout.flush();
  std::cerr.flush();
  const pid_t runner = ::getpid();
  pid_ = ::fork();
  if (pid_ < 0) {
    const int e = errno;
    ::close(sv[0]);
    ::close(sv[1]);
    errno = e;
    fail_errno("fork");
  }
  if (pid_ == 0) {
    ::close(sv[0]);
    for (const auto& other : others)
      ::close(other->socket());
    host_main(sv[1], warm_up, run, runner);
  }
  ::close(sv[1]);
  sock_ = sv[0];
}

TaskHost::~TaskHost() {
  ::close(sock_);
  int status = 0;
  waitpid_retrying(pid_, status);
}

std::vector<std::unique_ptr<TaskHost>> start_task_hosts(Loader& loader, const LoadedScenario& base,
                                                        const BackendRegistry& backends, bool trace,
                                                        int jobs) {
  std::vector<std::unique_ptr<TaskHost>> hosts;
  const BackendInfo* info = backends.find(base.expanded.value("backend", ""));
  if (!info || !info->make()->process_per_task()) return hosts;
  // Made in the host (shared by its workers through the fork), like the runner's own.
  auto backend = std::make_shared<std::unique_ptr<Backend>>();
  // The platform and workload files every worker needs are read once, in the host: one point
  // with each value of each sweep key (the first of the others).
  const auto warm_up = [&loader, &base, info, backend] {
    *backend = info->make();
    std::set<std::uint64_t> indexes = {0};
    std::uint64_t stride = base.point_count;
    for (const auto& key : base.sweep_keys) {
      const auto values = static_cast<std::uint64_t>(base.expanded.at("sweep").at(key).size());
      stride /= values;
      for (std::uint64_t v = 0; v < values && indexes.size() < 1000; ++v)
        indexes.insert(v * stride);
    }
    for (const std::uint64_t i : indexes)
      loader.point(base, i, true);
  };
  const auto run = [&loader, &base, backend, trace](const Task& task, const TaskInputs& in) {
    LoadedPoint lp = loader.point(base, task.point, true);
    if (task.corun) {  // the runner reads the co-run's outcome: no rows
      lp.sweep.id = UnregulatedCoruns::key(lp.scenario);
      lp.scenario = UnregulatedCoruns::scenario_of(lp.scenario);
      return execute(task, lp, **backend, in.baselines, trace);
    }
    TaskResult r = execute(task, lp, **backend, in.baselines, trace);
    if (r.ok && task.kind == Task::Kind::Point && !in.header.empty()) {  // here, in parallel
      r.samples_csv = samples_rows(lp.sweep.id, task.rep, r.outcome);
      r.row_csv = point_row(in.header, lp, task.rep, r.outcome, in.baselines, in.coruns);
      r.rows_made = true;
      r.outcome = {};
    }
    return r;
  };
  // No more hosts than CPUs online: more could not fork at the same time.
  const int cpus = std::max(1, static_cast<int>(::sysconf(_SC_NPROCESSORS_ONLN)));
  const int count = std::min((std::max(1, jobs) + kWorkersPerHost - 1) / kWorkersPerHost, cpus);
  for (int h = 0; h < count; ++h)
    hosts.push_back(std::make_unique<TaskHost>(warm_up, run, hosts));
  return hosts;
}

std::unique_ptr<Executor> make_executor(const RunState& st, bool process_per_task, int jobs,
                                        const std::vector<TaskHost*>& hosts) {
  if (!process_per_task) return std::make_unique<InProcessExecutor>(st);
  if (hosts.empty())
    throw ContractError("make_executor: a process-per-task backend needs a task host");
  return std::make_unique<HostExecutor>(st, std::max(1, jobs), hosts);
}

}  // namespace rosguard

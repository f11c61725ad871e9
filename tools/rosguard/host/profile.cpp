#include "host/profile.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <thread>

#include "core/error.h"
#include "load/files.h"
#include "load/host_model.h"
#include "load/loader.h"
#include "profile/callgrind.h"
#include "scenario/scenario.h"
#include "version.h"

#if ROSGUARD_WITH_SIM
#include "sim/calibration/isolation.h"
#include "sim/platform/sim_platform.h"
#include "sim/workload/profile.h"
#endif

namespace rosguard {

namespace {

namespace fs = std::filesystem;
using profile::AccessKind;
using profile::CacheGeometry;
using profile::TraceEvent;

std::vector<std::uint64_t> parse_list(const std::string& text, const std::string& option) {
  std::vector<std::uint64_t> values;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    std::uint64_t v = 0;
    std::size_t used = 0;
    try {
      if (item.empty() || item.front() == '-') throw std::invalid_argument(item);
      v = std::stoull(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != item.size() || v == 0 || v > (1ull << 30))
      throw InputError("", "",
                       option + " takes three positive integers L1,L2,L3 (got '" + text + "')");
    values.push_back(v);
  }
  if (values.size() != 3)
    throw InputError("", "", option + " takes three values L1,L2,L3 (got '" + text + "')");
  return values;
}

// The executable `name` would run: itself when it has a '/', else the first on PATH.
std::string find_executable(const std::string& name) {
  const auto runnable = [](const fs::path& p) {
    struct stat st {};
    return ::stat(p.c_str(), &st) == 0 && S_ISREG(st.st_mode) && ::access(p.c_str(), X_OK) == 0;
  };
  if (name.find('/') != std::string::npos) return runnable(name) ? name : "";
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path ? path : "");
  std::string dir;
  while (std::getline(dirs, dir, ':'))
    if (!dir.empty() && runnable(fs::path(dir) / name)) return (fs::path(dir) / name).string();
  return "";
}

std::string command_output(const std::string& command) {
  std::string out;
  if (FILE* p = ::popen(command.c_str(), "r")) {
    char buf[256];
    while (std::fgets(buf, sizeof buf, p))
      out += buf;
    ::pclose(p);
  }
  while (!out.empty() && (out.back() == '\n' || out.back() == '\r'))
    out.pop_back();
  return out;
}

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  ::gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

double round4(double x) {
  return std::round(x * 1e4) / 1e4;
}

std::string quoted_command(const std::vector<std::string>& command) {
  std::string s;
  for (const std::string& a : command) {
    if (!s.empty()) s += ' ';
    s += a.find_first_of(" \t'\"") == std::string::npos ? a : "'" + a + "'";
  }
  return s;
}

// Owns the child and the read end of its trace pipe; kills and reaps a child still running.
class Child {
 public:
  Child(pid_t pid, int fd) : pid_(pid), fd_(fd) {}
  ~Child() {
    if (fd_ >= 0) ::close(fd_);
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      int status = 0;
      while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
      }
    }
  }
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;
  int fd() const { return fd_; }
  // Closes the pipe and waits; returns the wait status.
  int wait(bool kill_first) {
    ::close(fd_);
    fd_ = -1;
    if (kill_first) ::kill(pid_, SIGKILL);
    int status = 0;
    while (::waitpid(pid_, &status, 0) < 0) {
      if (errno != EINTR) throw RunError(std::string("waitpid: ") + std::strerror(errno));
    }
    pid_ = -1;
    return status;
  }

 private:
  pid_t pid_;
  int fd_;
};

}  // namespace

profile::ProfilerConfig profile_config(const ProfileOptions& o) {
  const auto kb = parse_list(o.caches_kb, "--caches");
  const auto ways = parse_list(o.ways, "--ways");
  if (o.slice_instructions == 0) throw InputError("", "", "--slice-instructions must be positive");
  profile::ProfilerConfig c;
  const char* names[] = {"--caches/--ways L1", "--caches/--ways L2", "--caches/--ways L3"};
  CacheGeometry* g[] = {&c.l1, &c.l2, &c.l3};
  for (int i = 0; i < 3; ++i) {
    *g[i] = CacheGeometry{kb[i] * 1024, static_cast<unsigned>(ways[i]), 64};
    profile::check_geometry(*g[i], names[i]);
  }
  c.slice_instructions = o.slice_instructions;
  return c;
}

namespace {

// The program and valgrind, both found, and the run's record begun (InputError for a program
// that is not there, RunError without valgrind).
ProfileRun begin_run(const ProfileOptions& o, const std::string& tool, std::string& valgrind) {
  ProfileRun run;
  run.program = find_executable(o.command[0]);
  if (run.program.empty())
    throw InputError("", "", "program '" + o.command[0] + "' not found or not executable");
  valgrind = find_executable("valgrind");
  if (valgrind.empty())
    throw RunError(
        "valgrind is not installed (not found on PATH): rosguard profile runs the program under "
        "valgrind --tool=" +
        tool +
        "; install it with 'apt-get install valgrind' (or "
        "tools/install-deps.sh)");
  run.valgrind_version = command_output("'" + valgrind + "' --version 2>/dev/null");
  run.date_utc = utc_now();
  return run;
}

// Starts valgrind's lackey on the command, its trace on a pipe (fd 3 in the child).
Child start_lackey(const std::string& valgrind, const std::vector<std::string>& command) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) throw RunError(std::string("pipe: ") + std::strerror(errno));
  std::vector<std::string> args = {
      valgrind, "--tool=lackey", "--trace-mem=yes", "--basic-counts=no", "-q", "--log-fd=3"};
  args.insert(args.end(), command.begin(), command.end());
  std::vector<char*> argv;
  for (std::string& a : args)
    argv.push_back(a.data());
  argv.push_back(nullptr);

  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    throw RunError(std::string("fork: ") + std::strerror(errno));
  }
  if (pid == 0) {
    // The trace on fd 3; the program keeps stdin, stdout and stderr.
    // dup2 onto itself would keep O_CLOEXEC: clear it then.
    if (fds[1] == 3 ? ::fcntl(3, F_SETFD, 0) < 0 : ::dup2(fds[1], 3) < 0) ::_exit(127);
    ::execv(valgrind.c_str(), argv.data());
    ::_exit(127);
  }
  ::close(fds[1]);
  return Child(pid, fds[0]);
}

// The trace's lines into the profiler: --skip-instructions uncounted first, then at most
// --max-instructions.
class TraceFeed {
 public:
  TraceFeed(const ProfileOptions& o, profile::Profiler& profiler)
      : profiler_(profiler), max_(o.max_instructions), to_skip_(o.skip_instructions) {}

  // One read's bytes; a line cut by its end waits for the next. False when the whole chunk
  // only continued such a line.
  bool feed(std::string_view chunk) {
    std::size_t begin = 0;
    if (!carry_.empty()) {
      const auto nl = chunk.find('\n');
      if (nl == std::string_view::npos) {
        carry_.append(chunk);
        return false;
      }
      carry_.append(chunk.substr(0, nl));
      handle(carry_);
      carry_.clear();
      begin = nl + 1;
    }
    while (!stop_) {
      const auto nl = chunk.find('\n', begin);
      if (nl == std::string_view::npos) {
        carry_.assign(chunk.substr(begin));
        break;
      }
      handle(chunk.substr(begin, nl - begin));
      begin = nl + 1;
    }
    return true;
  }
  // The trace ended: its last line, if it had no newline.
  void finish() {
    if (!stop_ && !carry_.empty()) handle(carry_);
  }
  // Every 4 M instructions counted: time to see whether a progress line is due.
  bool progress_check_due() {
    if (profiler_.instructions() < next_check_) return false;
    next_check_ = profiler_.instructions() + (1 << 22);
    return true;
  }
  bool stopped() const { return stop_; }  // --max-instructions reached
  bool skipping() const { return to_skip_ > 0; }

 private:
  void handle(std::string_view line) {
    const auto e = profile::parse_lackey_line(line);
    if (!e) {
      if (!line.empty()) std::cerr << "valgrind: " << line << "\n";
      return;
    }
    switch (e->kind) {
      case TraceEvent::Kind::Instruction:
        if (to_skip_ > 0 && profiler_.instructions() == to_skip_) {
          profiler_.reset_counts();
          to_skip_ = 0;
          next_check_ = 1 << 22;
        }
        if (max_ && to_skip_ == 0 && profiler_.instructions() >= max_) {
          stop_ = true;
          return;
        }
        profiler_.instruction();
        break;
      case TraceEvent::Kind::Load:
        profiler_.access(e->address, e->size, AccessKind::Load);
        break;
      case TraceEvent::Kind::Store:
        profiler_.access(e->address, e->size, AccessKind::Store);
        break;
      case TraceEvent::Kind::Modify:
        profiler_.access(e->address, e->size, AccessKind::Modify);
        break;
    }
  }

  profile::Profiler& profiler_;
  const std::uint64_t max_;
  std::uint64_t to_skip_;
  std::uint64_t next_check_ = 1 << 22;
  std::string carry_;  // a line cut by the end of a read
  bool stop_ = false;
};

// Reads the trace until it ends or --max-instructions; a progress line at most every 5 s.
void read_trace(Child& child, TraceFeed& feed, const profile::Profiler& profiler,
                std::chrono::steady_clock::time_point start, std::ostream* progress) {
  // lackey writes every trace line with its own write(2). A reader blocked on the pipe is woken
  // by each of them (two context switches per line: most of the run's time); a reader that lets
  // the pipe fill between reads is woken by none. So: a large pipe (best effort: the default
  // 64 KB when the kernel refuses), and a short sleep whenever a read found it less than a
  // quarter full.
  const int pipe_size = ::fcntl(child.fd(), F_SETPIPE_SZ, 1 << 20);
  const std::size_t drained = pipe_size > 0 ? static_cast<std::size_t>(pipe_size) / 4 : 16384;
  const timespec pause{0, 1'000'000};  // 1 ms: about 50 KB of trace at lackey's pace

  std::vector<char> buf(1 << 20);
  auto last_report = start;
  while (!feed.stopped()) {
    const ssize_t n = ::read(child.fd(), buf.data(), buf.size());
    if (n < 0) {
      if (errno == EINTR) continue;
      throw RunError(std::string("reading the trace: ") + std::strerror(errno));
    }
    if (n == 0) break;
    if (static_cast<std::size_t>(n) < drained) ::nanosleep(&pause, nullptr);
    if (!feed.feed(std::string_view(buf.data(), static_cast<std::size_t>(n)))) continue;
    if (progress && feed.progress_check_due()) {
      const auto now = std::chrono::steady_clock::now();
      if (now - last_report >= std::chrono::seconds(5)) {
        last_report = now;
        const double s = std::chrono::duration<double>(now - start).count();
        char line[160];
        std::snprintf(line, sizeof line, "profile: %.1f M instructions%s after %.0f s\n",
                      static_cast<double>(profiler.instructions()) / 1e6,
                      feed.skipping() ? " skipped" : "", s);
        *progress << line << std::flush;
      }
    }
  }
  feed.finish();
}

// The CPU time of rosguard (the profiler) and of its children (valgrind and the program).
void record_cpu_times(ProfileRun& run) {
  const auto seconds = [](const timeval& t) {
    return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_usec) / 1e6;
  };
  rusage usage{};
  if (::getrusage(RUSAGE_SELF, &usage) == 0)
    run.profiler_cpu_seconds = seconds(usage.ru_utime) + seconds(usage.ru_stime);
  if (::getrusage(RUSAGE_CHILDREN, &usage) == 0)
    run.tracer_cpu_seconds = seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

// No profile from a program that failed, a trace that ended inside --skip-instructions or one
// without instructions.
void check_trace_end(const ProfileOptions& o, const profile::Profiler& profiler,
                     const TraceFeed& feed, int status) {
  if (!feed.stopped()) {
    if (WIFEXITED(status) && WEXITSTATUS(status) != 0)
      throw RunError("'" + quoted_command(o.command) + "' failed under valgrind: exit status " +
                     std::to_string(WEXITSTATUS(status)) + "; no profile written");
    if (WIFSIGNALED(status))
      throw RunError("'" + quoted_command(o.command) + "' was killed by signal " +
                     std::to_string(WTERMSIG(status)) + " (" + ::strsignal(WTERMSIG(status)) +
                     ") under valgrind; no profile written");
  }
  if (feed.skipping())
    throw RunError("'" + quoted_command(o.command) + "' ended after " +
                   std::to_string(profiler.instructions()) + " instructions, before the " +
                   std::to_string(o.skip_instructions) +
                   " of --skip-instructions; no profile written");
  if (profiler.instructions() == 0)
    throw RunError("the trace of '" + quoted_command(o.command) +
                   "' has no instructions: is it valgrind lackey's?");
}

}  // namespace

ProfileRun trace_program(const ProfileOptions& o, profile::Profiler& profiler,
                         std::ostream* progress) {
  if (o.command.empty()) throw InputError("", "", "no program given: rosguard profile -- PROGRAM");
  std::string valgrind;
  ProfileRun run = begin_run(o, "lackey", valgrind);

  const auto start = std::chrono::steady_clock::now();
  Child child = start_lackey(valgrind, o.command);
  TraceFeed feed(o, profiler);
  read_trace(child, feed, profiler, start, progress);
  const int status = child.wait(feed.stopped());
  run.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  run.bounded = feed.stopped();
  record_cpu_times(run);
  profiler.finish();
  check_trace_end(o, profiler, feed, status);
  return run;
}

namespace {

// A scratch folder, removed with what is in it.
class ScratchDir {
 public:
  ScratchDir() {
    const char* tmp = std::getenv("TMPDIR");
    std::string pattern = std::string(tmp && *tmp ? tmp : "/tmp") + "/rosguard-profile-XXXXXX";
    if (!::mkdtemp(pattern.data()))
      throw RunError("cannot make a scratch folder " + pattern + ": " + std::strerror(errno));
    path_ = pattern;
  }
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

// One callgrind run: LL of `ll_bytes`; its dumps are out_file, out_file.1, out_file.2, ...
struct CallgrindRun {
  std::string label;
  std::uint64_t ll_bytes = 0;
  unsigned ll_ways = 0;
  fs::path out_file, log_file;
  pid_t pid = -1;
  int status = 0;
  bool done = false;
};

pid_t start_callgrind(const std::string& valgrind, const ProfileOptions& o,
                      const profile::ProfilerConfig& c, const CallgrindRun& r, bool own_output) {
  const auto cache = [](std::uint64_t bytes, unsigned ways) {
    return std::to_string(bytes) + "," + std::to_string(ways) + ",64";
  };
  std::vector<std::string> args = {
      valgrind,
      "--tool=callgrind",
      "-q",
      "--cache-sim=yes",
      "--simulate-wb=yes",
      "--I1=65536,4,64",
      "--D1=" + cache(c.l1.size_bytes, c.l1.ways),
      "--LL=" + cache(r.ll_bytes, r.ll_ways),
      "--dump-every-bb=" + std::to_string(std::max<std::uint64_t>(1000, c.slice_instructions / 4)),
      "--callgrind-out-file=" + r.out_file.string(),
      "--log-file=" + r.log_file.string()};
  args.insert(args.end(), o.command.begin(), o.command.end());
  std::vector<char*> argv;
  for (std::string& a : args)
    argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) throw RunError(std::string("fork: ") + std::strerror(errno));
  if (pid == 0) {
    // The first run keeps the program's output; the others' would only repeat it.
    if (!own_output) {
      const int null = ::open("/dev/null", O_WRONLY);
      if (null >= 0) {
        ::dup2(null, 1);
        ::dup2(null, 2);
      }
    }
    ::execv(valgrind.c_str(), argv.data());
    ::_exit(127);
  }
  return pid;
}

std::string file_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// A run's dumps, in part order (every file out_file*).
std::vector<profile::CallgrindDump> read_dumps(const CallgrindRun& r) {
  std::vector<profile::CallgrindDump> dumps;
  for (const auto& entry : fs::directory_iterator(r.out_file.parent_path())) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(r.out_file.filename().string(), 0) != 0) continue;
    if (auto d = profile::parse_callgrind_dump(file_text(entry.path())))
      dumps.push_back(std::move(*d));
  }
  std::sort(dumps.begin(), dumps.end(),
            [](const auto& a, const auto& b) { return a.part < b.part; });
  return dumps;
}

}  // namespace

ProfileRun callgrind_program(const ProfileOptions& o, ProfileData& data, std::ostream* progress) {
  if (o.command.empty()) throw InputError("", "", "no program given: rosguard profile -- PROGRAM");
  const profile::Profiler shape(profile_config(o));  // the capacities, checked geometry
  const profile::ProfilerConfig& c = shape.config();
  std::string valgrind;
  ProfileRun run = begin_run(o, "callgrind", valgrind);

  // Run 0: LL = the L2. Then one per MRC capacity other than the L2's, and one with an LL far
  // beyond any footprint here, whose misses are the lines first touched (the footprint).
  ScratchDir scratch;
  std::vector<CallgrindRun> runs;
  const auto add = [&](std::string label, std::uint64_t bytes, unsigned ways) {
    const unsigned w = profile::callgrind_ways(bytes, ways, 64);
    if (w == 0)
      throw InputError("", "",
                       label + " of " + std::to_string(bytes / 1024) +
                           " KB: callgrind needs a power-of-two number of 64-byte sets at some "
                           "associativity up to 64; choose another size");
    CallgrindRun r;
    r.label = std::move(label);
    r.ll_bytes = bytes;
    r.ll_ways = w;
    r.out_file = scratch.path() / ("run" + std::to_string(runs.size()) + ".out");
    r.log_file = scratch.path() / ("run" + std::to_string(runs.size()) + ".log");
    runs.push_back(std::move(r));
  };
  add("L2", c.l2.size_bytes, c.l2.ways);
  std::vector<std::size_t> run_of_capacity;
  for (const std::uint64_t kb : shape.capacities_kb()) {
    // An L3 no larger than the L2 misses all the L2 misses: the L2 run answers.
    if (kb * 1024 <= c.l2.size_bytes) {
      run_of_capacity.push_back(0);
      continue;
    }
    run_of_capacity.push_back(runs.size());
    add("MRC capacity", kb * 1024, kb * 1024 == c.l3.size_bytes ? c.l3.ways : 16);
  }
  constexpr std::uint64_t kFootprintLl = 1ull << 30;  // 1 GB: the lines first touched
  const std::size_t footprint_run = runs.size();
  add("footprint", kFootprintLl, 16);

  unsigned jobs = o.jobs ? o.jobs : std::max(1u, std::thread::hardware_concurrency());
  const auto start = std::chrono::steady_clock::now();
  auto last_report = start;
  std::size_t next = 0, running = 0, finished = 0;
  const auto kill_all = [&] {
    for (CallgrindRun& r : runs)
      if (r.pid > 0 && !r.done) {
        ::kill(r.pid, SIGKILL);
        ::waitpid(r.pid, nullptr, 0);
        r.done = true;
      }
  };
  try {
    while (finished < runs.size()) {
      while (running < jobs && next < runs.size()) {
        runs[next].pid = start_callgrind(valgrind, o, c, runs[next], next == 0);
        ++next;
        ++running;
      }
      int status = 0;
      const pid_t pid = ::waitpid(-1, &status, WNOHANG);
      if (pid < 0 && errno != EINTR)
        throw RunError(std::string("waitpid: ") + std::strerror(errno));
      if (pid > 0) {
        for (CallgrindRun& r : runs)
          if (r.pid == pid) {
            r.done = true;
            r.status = status;
            --running;
            ++finished;
            if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
              const std::string log = file_text(r.log_file);
              throw RunError(
                  "'" + quoted_command(o.command) + "' failed under valgrind callgrind (" +
                  (WIFEXITED(status) ? "exit status " + std::to_string(WEXITSTATUS(status))
                                     : std::string("signal ") + ::strsignal(WTERMSIG(status))) +
                  ")" + (log.empty() ? std::string() : ": " + log) + "; no profile written");
            }
          }
        continue;
      }
      ::usleep(100'000);
      const auto now = std::chrono::steady_clock::now();
      if (progress && now - last_report >= std::chrono::seconds(5)) {
        last_report = now;
        std::size_t dumps = 0;
        for (const auto& entry : fs::directory_iterator(scratch.path()))
          dumps += entry.path().extension() != ".log";
        char line[200];
        std::snprintf(line, sizeof line,
                      "profile: callgrind: %zu of %zu runs done, %zu running (%u at a time), "
                      "%zu slices dumped, after %.0f s\n",
                      finished, runs.size(), running, jobs, dumps,
                      std::chrono::duration<double>(now - start).count());
        *progress << line << std::flush;
      }
    }
  } catch (...) {
    kill_all();
    throw;
  }
  run.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  run.tracer_runs = static_cast<int>(runs.size());
  record_cpu_times(run);

  const auto l2_dumps = read_dumps(runs[0]);
  std::vector<std::vector<profile::CallgrindDump>> capacity_dumps;
  for (const std::size_t i : run_of_capacity)
    capacity_dumps.push_back(i == 0 ? l2_dumps : read_dumps(runs[i]));
  profile::CallgrindSlices slices = profile::callgrind_slices(l2_dumps, capacity_dumps);
  for (const std::size_t i : slices.misaligned)
    std::cerr << "warning: the callgrind run with an L3 of " << shape.capacities_kb()[i]
              << " KB did not execute as the L2 run did (other instruction counts per dump): "
                 "its misses are spread over the slices by their L2 refills\n";

  // --skip-instructions and --max-instructions, at dump granularity.
  std::uint64_t seen = 0;
  data.slices.clear();
  for (const profile::SliceCounts& s : slices.slices) {
    const std::uint64_t begin = seen;
    seen += s.instructions;
    if (begin < o.skip_instructions) continue;
    if (o.max_instructions && data.instructions >= o.max_instructions) {
      run.bounded = true;
      break;
    }
    data.slices.push_back(s);
    data.instructions += s.instructions;
  }
  if (data.instructions == 0)
    throw RunError("'" + quoted_command(o.command) + "' ended after " + std::to_string(seen) +
                   " instructions" +
                   (o.skip_instructions ? ", before the " + std::to_string(o.skip_instructions) +
                                              " of --skip-instructions"
                                        : std::string()) +
                   "; no profile written");
  // The footprint: compulsory misses of the 1 GB run over the counted dumps.
  const auto fp = read_dumps(runs[footprint_run]);
  seen = 0;
  std::uint64_t counted = 0;
  for (const profile::CallgrindDump& d : fp) {
    const std::uint64_t begin = seen;
    seen += d.at("Ir");
    if (begin < o.skip_instructions) continue;
    if (o.max_instructions && counted >= o.max_instructions) break;
    counted += d.at("Ir");
    data.footprint_lines += d.at("DLmr") + d.at("DLmw");
  }
  data.config = c;
  data.capacities_kb = shape.capacities_kb();
  data.mlp_measured = false;
  std::ostringstream m;
  m << "--tool=callgrind --cache-sim=yes --simulate-wb=yes, " << runs.size()
    << " runs of the program (" << jobs << " at a time): D1 = the L1, LL = the L2, each MRC "
    << "capacity (16-way), and 1 GB for the footprint (the lines first touched)";
  data.method = m.str();
  data.cache_model = "callgrind's set-associative LRU caches (inclusive LL)";
  return run;
}

ProfileData profile_data(const profile::Profiler& profiler) {
  ProfileData d;
  d.config = profiler.config();
  d.capacities_kb = profiler.capacities_kb();
  d.slices = profiler.slices();
  d.instructions = profiler.instructions();
  d.footprint_lines = profiler.footprint_lines();
  d.method = "--tool=lackey --trace-mem=yes";
  d.cache_model = "Data accesses through an LRU model of the target";
  return d;
}

nlohmann::json workload_document(const ProfileOptions& o, const ProfileData& data,
                                 const ProfileRun& run) {
  using nlohmann::json;
  const profile::ProfilerConfig& c = data.config;
  const auto& caps = data.capacities_kb;
  const auto phases = profile::merge_phases(data.slices);
  profile::SliceCounts total;
  total.l3_misses.assign(caps.size(), 0);
  for (const profile::SliceCounts& s : data.slices)
    total.add(s);
  const double instructions = static_cast<double>(data.instructions);

  const auto mrc = [&](const profile::SliceCounts& s) {
    json curve = json::array();
    for (std::size_t i = 0; i < caps.size(); ++i)
      curve.push_back({{"capacity_kb", caps[i]},
                       {"miss_ratio", round4(static_cast<double>(s.l3_misses[i]) /
                                             static_cast<double>(s.l2_refills))}});
    return curve;
  };
  json phase_list = json::array();
  for (const profile::Phase& p : phases) {
    json ph = {{"fraction", static_cast<double>(p.counts.instructions) / instructions},
               {"base_ipc", 1.0},
               {"l2_refill_pki", round4(p.counts.pki(p.counts.l2_refills))},
               {"l2_wb_pki", round4(p.counts.pki(p.counts.l2_writebacks))}};
    if (data.mlp_measured) ph["mlp"] = round4(std::clamp(p.counts.mlp(), 1.0, 64.0));
    if (p.counts.l2_refills > 0) ph["mrc"] = mrc(p.counts);
    phase_list.push_back(ph);
  }
  std::size_t l3_index = 0;
  while (caps[l3_index] != c.l3.size_bytes / 1024)
    ++l3_index;
  const double l3_hit = total.l2_refills ? 1.0 - static_cast<double>(total.l3_misses[l3_index]) /
                                                     static_cast<double>(total.l2_refills)
                                         : 1.0;

  std::string name = o.name;
  if (name.empty()) {
    name = fs::path(o.command[0]).filename().string();
    for (char& ch : name)
      if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '.' && ch != '_' && ch != '-')
        ch = '_';
    if (name.empty() || !std::isalnum(static_cast<unsigned char>(name[0]))) name = "p" + name;
  }
  const auto geometry = [](const char* level, const CacheGeometry& g) {
    return std::string(level) + " " + std::to_string(g.size_bytes / 1024) + " KB " +
           std::to_string(g.ways) + "-way";
  };
  std::ostringstream src;
  src << "rosguard profile " << kVersion << " (" << kGitRevision << ") on " << run.date_utc << ": '"
      << quoted_command(o.command) << "' (program " << run.program << ", run in "
      << fs::current_path().string() << ") under " << run.valgrind_version << " " << data.method
      << (o.skip_instructions
              ? ", the first " + std::to_string(o.skip_instructions) +
                    " instructions run through the caches uncounted (--skip-instructions)"
              : std::string())
      << (run.bounded ? ", stopped after " + std::to_string(o.max_instructions) +
                            " counted instructions (--max-instructions)"
                      : std::string(o.skip_instructions ? ", to the end" : ", whole run"))
      << ". " << data.cache_model << ": " << geometry("L1", c.l1) << ", " << geometry("L2", c.l2)
      << ", " << geometry("L3", c.l3);
  if (data.mlp_measured)
    src << ", 64-byte lines, write-back, write-allocate, L1/L2 non-inclusive. Slices of "
        << c.slice_instructions << " instructions, adjacent slices with similar L2 refill and "
        << "write-back rates merged into " << phases.size()
        << " phases. l3_hit and each phase's mrc: the L2 refills that hit in a fully associative "
           "LRU L3 fed the L2 miss stream (Mattson stack distances). mlp: L2 refills within "
        << c.mlp_window_instructions
        << " instructions of each other, an upper bound (the trace does not show dependences).";
  else
    src << ". Slices of about " << c.slice_instructions
        << " instructions (callgrind dumps by basic blocks), adjacent slices with similar L2 "
           "refill and write-back rates merged into "
        << phases.size()
        << " phases. mlp is not measured (callgrind counts show no overlap of refills): the sim "
           "takes 1, so the profile's memory stalls under contention are an upper bound.";

  json placeholder = json::array({"base_ipc"});
  if (!data.mlp_measured) placeholder.push_back("mlp");
  json doc{{"name", name},
           {"description", "Profiled from '" + quoted_command(o.command) +
                               "' by rosguard profile (" + o.tracer + ")."},
           {"sim",
            {{"instructions", instructions},
             {"footprint_kb",
              round4(static_cast<double>(data.footprint_lines) * c.l1.line_bytes / 1024.0)},
             {"l3_hit", round4(l3_hit)},
             {"phases", phase_list},
             {"placeholder", placeholder},
             {"source", src.str()}}}};
  // A whole run: the hw backend runs the program itself, from where it was profiled.
  if (!run.bounded && o.skip_instructions == 0) {
    json command = json::array({fs::absolute(run.program).lexically_normal().string()});
    for (std::size_t i = 1; i < o.command.size(); ++i)
      command.push_back(o.command[i]);
    doc["command"] = command;
    doc["cwd"] = fs::current_path().string();
  }
  return doc;
}

namespace {

// The program run natively `repeat` times on this machine: the median CPU time (user + system)
// of one run, with its own output left alone.
double measure_cpu_seconds(const ProfileOptions& o, const std::string& program, int repeat) {
  std::vector<double> seconds;
  for (int i = 0; i < repeat; ++i) {
    std::vector<std::string> args = o.command;
    args[0] = program;
    std::vector<char*> argv;
    for (std::string& a : args)
      argv.push_back(a.data());
    argv.push_back(nullptr);
    const pid_t pid = ::fork();
    if (pid < 0) throw RunError(std::string("fork: ") + std::strerror(errno));
    if (pid == 0) {
      const int null = ::open("/dev/null", O_WRONLY);
      if (null >= 0) ::dup2(null, 1);
      ::execv(program.c_str(), argv.data());
      ::_exit(127);
    }
    int status = 0;
    rusage usage{};
    while (::wait4(pid, &status, 0, &usage) < 0)
      if (errno != EINTR) throw RunError(std::string("wait4: ") + std::strerror(errno));
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
      throw RunError("'" + quoted_command(o.command) +
                     "' failed when run alone to measure its IPC; no profile written");
    const auto sec = [](const timeval& t) {
      return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_usec) / 1e6;
    };
    seconds.push_back(sec(usage.ru_utime) + sec(usage.ru_stime));
  }
  std::sort(seconds.begin(), seconds.end());
  return seconds[seconds.size() / 2];
}

std::string sig4(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

// The platform --platform names: "host" (the installed model of this machine), a platform file,
// or a name under the platforms folder.
PlatformInfo profile_platform(const ProfileOptions& o, const SchemaSet& schemas) {
  if (o.platform == "host") {
    auto installed = installed_host_model(schemas);
    if (!installed)
      throw InputError("", "",
                       "--platform host: no calibrated model of this host: run `rosguard "
                       "calibrate --install` first (it writes " +
                           host_model_path().string() + ")");
    PlatformInfo info = build_platform(installed->doc, installed->origin);
    info.origin = installed->origin;
    return info;
  }
  fs::path path = o.platform;
  if (!fs::is_regular_file(path)) path = o.platforms_dir / (o.platform + ".json");
  if (!fs::is_regular_file(path))
    throw InputError("", "",
                     "--platform '" + o.platform + "': neither a file nor a platform under " +
                         o.platforms_dir.string() + " (rosguard list platforms)");
  nlohmann::json doc = read_json_file(path, path.string());
  schemas.validate(doc, SchemaKind::Platform, path.string());
  schemas.apply_defaults(doc, SchemaKind::Platform);
  return build_platform(doc, path.string());
}

// Fits the document's base_ipc (all phases by one factor) so that its isolation IPC on the
// platform equals `ipc`; says how in the source and the reference.
void fit_document(nlohmann::json& doc, const ProfileOptions& o, const std::string& how, double ipc,
                  const SchemaSet& schemas) {
#if ROSGUARD_WITH_SIM
  const PlatformInfo platform = profile_platform(o, schemas);
  const sim::SimPlatform plat = sim::parse_sim_platform(platform);
  WorkloadInfo info{doc.at("name").get<std::string>(), o.out, doc};
  sim::WorkloadProfile w = sim::parse_profile(info, plat, o.out, "/sim");
  const double before = sim::isolation_steady_state(plat, w).ipc;
  const sim::IsolationFigures fig = sim::fit_isolation(plat, w, ipc);
  // The workload schema's bound on base_ipc; an IPC the memory stalls alone forbid ends there.
  constexpr double kMaxBaseIpc = 16.0;
  double highest = 0;
  for (const sim::Phase& ph : w.phases)
    highest = std::max(highest, ph.base_ipc);
  if (std::abs(fig.ipc / ipc - 1.0) > 0.01 || highest > kMaxBaseIpc)
    throw InputError("", "",
                     "cannot fit base_ipc to IPC " + sig4(ipc) + " (" + how + ") on platform '" +
                         platform.name +
                         "': the profile's memory stalls there allow at most "
                         "about " +
                         sig4(sim::isolation_steady_state(plat,
                                                          [&] {
                                                            sim::WorkloadProfile top = w;
                                                            for (sim::Phase& ph : top.phases)
                                                              ph.base_ipc = kMaxBaseIpc;
                                                            return top;
                                                          }())
                                  .ipc) +
                         " (base_ipc at its bound " + sig4(kMaxBaseIpc) +
                         "); is the IPC from the machine the platform models, and the profile's "
                         "caches that machine's (--platform, --caches)?");
  auto& phases = doc["sim"]["phases"];
  for (std::size_t i = 0; i < w.phases.size(); ++i)
    phases[i]["base_ipc"] = std::stod(sig4(w.phases[i].base_ipc));
  auto& placeholder = doc["sim"]["placeholder"];
  placeholder.erase(std::remove(placeholder.begin(), placeholder.end(), "base_ipc"),
                    placeholder.end());
  if (placeholder.empty()) doc["sim"].erase("placeholder");
  const double factor = w.phases.empty() ? 1.0 : w.phases.front().base_ipc;
  doc["sim"]["source"] =
      doc["sim"]["source"].get<std::string>() + " base_ipc fitted (all phases x " + sig4(factor) +
      ") on platform '" + platform.name + "' (" + platform.origin + ") to IPC " + sig4(ipc) + ", " +
      how + ": the sim's isolation IPC " + sig4(before) + " before, " + sig4(fig.ipc) + " after.";
  doc["reference"] = {{"ipc", std::stod(sig4(ipc))},
                      {"source", "IPC " + how + " (rosguard profile, " + utc_now() + ")"}};
#else
  (void)doc, (void)o, (void)how, (void)ipc, (void)schemas;
  throw InputError("", "",
                   "--fit-ipc and --measure-ipc need the sim backend, which this "
                   "rosguard is built without");
#endif
}

}  // namespace

int profile_command(const ProfileOptions& given, const SchemaSet& schemas) {
  ProfileOptions o = given;
  if (o.caches_from_platform) {
    const PlatformInfo p = profile_platform(o, schemas);
    const nlohmann::json caches = p.doc.get().value("caches", nlohmann::json::object());
    const auto kb = [&](const char* key) {
      if (!caches.contains(key))
        throw InputError(
            p.origin, std::string("/caches/") + key,
            "--platform '" + o.platform + "' gives no size for this cache: give --caches L1,L2,L3");
      return std::to_string(std::llround(caches.at(key).get<double>()));
    };
    o.caches_kb = kb("l1d_kb") + "," + kb("l2_kb") + "," + kb("l3_kb_per_cluster");
  }
  if (o.out.empty()) throw InputError("", "", "--out is required: the workload JSON to write");
  if (o.tracer != "lackey" && o.tracer != "callgrind")
    throw InputError("", "", "--tracer must be lackey or callgrind, not '" + o.tracer + "'");
  [[maybe_unused]] const bool fit = o.fit_ipc > 0 || o.measure_ipc;
  if (o.fit_ipc > 0 && o.measure_ipc)
    throw InputError("", "", "--fit-ipc and --measure-ipc: give one of them");
  if (o.measure_ipc && (o.max_instructions || o.skip_instructions))
    throw InputError("", "",
                     "--measure-ipc times the whole program, so it cannot fit a window "
                     "(--skip-instructions / --max-instructions): give the IPC of the window "
                     "with --fit-ipc");
#if ROSGUARD_WITH_SIM
  if (fit) (void)profile_platform(o, schemas);  // a bad --platform before the tracing
#endif
  ProfileData data;
  ProfileRun run;
  std::ostream* progress = o.quiet ? nullptr : &std::cerr;
  if (o.tracer == "callgrind") {
    run = callgrind_program(o, data, progress);
  } else {
    profile::Profiler profiler(profile_config(o));
    run = trace_program(o, profiler, progress);
    data = profile_data(profiler);
  }
  nlohmann::json doc = workload_document(o, data, run);
  std::string fitted;
  if (o.fit_ipc > 0) {
    fit_document(doc, o, "given with --fit-ipc", o.fit_ipc, schemas);
    fitted = "base_ipc fitted to IPC " + sig4(o.fit_ipc);
  } else if (o.measure_ipc) {
    const double cpu = measure_cpu_seconds(o, run.program, o.repeat);
#if ROSGUARD_WITH_SIM
    const double ghz = sim::parse_sim_platform(profile_platform(o, schemas)).freq_ghz();
#else
    const double ghz = 1.0;
#endif
    const double ipc = static_cast<double>(data.instructions) / (cpu * ghz * 1e9);
    fit_document(doc, o,
                 "measured here: " + std::to_string(data.instructions) + " instructions in " +
                     sig4(cpu) + " CPU s (median of " + std::to_string(o.repeat) +
                     " native runs) at the platform's " + sig4(ghz) + " GHz",
                 ipc, schemas);
    fitted = "base_ipc fitted to IPC " + sig4(ipc) + " (measured: " + sig4(cpu) +
             " CPU s a run, median of " + std::to_string(o.repeat) + ")";
  }
  if (fitted.empty())
    doc["sim"]["source"] =
        doc["sim"]["source"].get<std::string>() +
        " base_ipc is a placeholder (1.0) until fitted to a measured IPC (rosguard profile "
        "--fit-ipc or --measure-ipc).";
  schemas.validate(doc, SchemaKind::Workload, o.out);
  write_file_atomic(o.out, doc.dump(2) + "\n");
  if (!o.slices_csv.empty()) {
    std::ostringstream csv;
    csv << "first_instruction,instructions,loads,stores,l1_refills,l1_writebacks,l2_refills,"
           "l2_writebacks";
    for (const std::uint64_t kb : data.capacities_kb)
      csv << ",l3_misses_" << kb << "kb";
    csv << "\n";
    std::uint64_t first = 0;
    for (const profile::SliceCounts& s : data.slices) {
      csv << first << ',' << s.instructions << ',' << s.loads << ',' << s.stores << ','
          << s.l1_refills << ',' << s.l1_writebacks << ',' << s.l2_refills << ','
          << s.l2_writebacks;
      for (const std::uint64_t m : s.l3_misses)
        csv << ',' << m;
      csv << "\n";
      first += s.instructions;
    }
    write_file_atomic(o.slices_csv, csv.str());
  }
  if (!o.quiet) {
    profile::SliceCounts t;
    t.l3_misses.assign(data.capacities_kb.size(), 0);
    for (const profile::SliceCounts& s : data.slices)
      t.add(s);
    char line[640];
    std::snprintf(
        line, sizeof line,
        "profile: %s: %llu instructions%s in %.1f s (%s); loads %llu, stores %llu; "
        "L1 refills %.3f pki, L2 refills %.3f pki, L2 write-backs %.3f pki; "
        "footprint %.0f KB; %zu phases; CPU: valgrind %.1f s, profiler %.1f s "
        "(%.2f M instructions traced, skipped ones included, per CPU second%s)\n",
        o.out.c_str(), static_cast<unsigned long long>(data.instructions),
        run.bounded ? " (bounded)" : "", run.wall_seconds, o.tracer.c_str(),
        static_cast<unsigned long long>(t.loads), static_cast<unsigned long long>(t.stores),
        t.pki(t.l1_refills), t.pki(t.l2_refills), t.pki(t.l2_writebacks),
        doc["sim"]["footprint_kb"].get<double>(), doc["sim"]["phases"].size(),
        run.tracer_cpu_seconds, run.profiler_cpu_seconds,
        static_cast<double>(o.skip_instructions + data.instructions) * run.tracer_runs / 1e6 /
            std::max(1e-9, run.tracer_cpu_seconds + run.profiler_cpu_seconds),
        run.tracer_runs > 1 ? (" and run, " + std::to_string(run.tracer_runs) + " runs").c_str()
                            : "");
    std::cerr << line;
    if (!fitted.empty())
      std::cerr << "profile: " << fitted << "\n";
    else
      std::cerr << "profile: base_ipc is a placeholder (1.0): the sim's timing of this workload "
                   "means nothing until it is fitted: rosguard profile ... --platform P "
                   "--fit-ipc IPC (measured on the target), or --measure-ipc (this machine, "
                   "platform host)\n";
    if (!doc.contains("command"))
      std::cerr << "profile: no \"command\" written (the profile covers a window, not a run): "
                   "the hw backend cannot run this workload as it stands\n";
  }
  return 0;
}

}  // namespace rosguard

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
#include <iostream>
#include <sstream>

#include "core/error.h"
#include "load/files.h"
#include "version.h"

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
  ProfileRun run;
  run.program = find_executable(o.command[0]);
  if (run.program.empty())
    throw InputError("", "", "program '" + o.command[0] + "' not found or not executable");
  const std::string valgrind = find_executable("valgrind");
  if (valgrind.empty())
    throw RunError(
        "valgrind is not installed (not found on PATH): rosguard profile runs the program under "
        "valgrind --tool=lackey; install it with 'apt-get install valgrind' (or "
        "tools/install-deps.sh)");
  run.valgrind_version = command_output("'" + valgrind + "' --version 2>/dev/null");
  run.date_utc = utc_now();

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

nlohmann::json workload_document(const ProfileOptions& o, const profile::Profiler& profiler,
                                 const ProfileRun& run) {
  using nlohmann::json;
  const profile::ProfilerConfig& c = profiler.config();
  const auto& caps = profiler.capacities_kb();
  const auto phases = profile::merge_phases(profiler.slices());
  const profile::SliceCounts total = profiler.total();
  const double instructions = static_cast<double>(profiler.instructions());

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
               {"l2_wb_pki", round4(p.counts.pki(p.counts.l2_writebacks))},
               {"mlp", round4(std::clamp(p.counts.mlp(), 1.0, 64.0))}};
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
      << fs::current_path().string() << ") under " << run.valgrind_version
      << " --tool=lackey --trace-mem=yes"
      << (o.skip_instructions
              ? ", the first " + std::to_string(o.skip_instructions) +
                    " instructions run through the caches uncounted (--skip-instructions)"
              : std::string())
      << (run.bounded ? ", stopped after " + std::to_string(o.max_instructions) +
                            " counted instructions (--max-instructions)"
                      : std::string(o.skip_instructions ? ", to the end" : ", whole run"))
      << ". Data accesses through an LRU model of the target: " << geometry("L1", c.l1) << ", "
      << geometry("L2", c.l2) << ", " << geometry("L3", c.l3)
      << ", 64-byte lines, write-back, write-allocate, L1/L2 non-inclusive. Slices of "
      << c.slice_instructions << " instructions, adjacent slices with similar L2 refill and "
      << "write-back rates merged into " << phases.size()
      << " phases. l3_hit and each phase's mrc: the L2 refills that hit in a fully associative LRU"
      << " L3 fed the L2 miss stream (Mattson stack distances). mlp: L2 refills within "
      << c.mlp_window_instructions
      << " instructions of each other, an upper bound (the trace does not show dependences). "
         "base_ipc is a placeholder (1.0): fit it with rosguard-sim-calibrate --fit against the "
         "measured IPC before using the profile for timing.";
  return json{{"name", name},
              {"description", "Profiled from '" + quoted_command(o.command) +
                                  "' by rosguard profile (valgrind lackey + cache model)."},
              {"sim",
               {{"instructions", instructions},
                {"footprint_kb", round4(static_cast<double>(profiler.footprint_lines()) *
                                        c.l1.line_bytes / 1024.0)},
                {"l3_hit", round4(l3_hit)},
                {"phases", phase_list},
                {"source", src.str()}}}};
}

int profile_command(const ProfileOptions& o, const SchemaSet& schemas) {
  if (o.out.empty()) throw InputError("", "", "--out is required: the workload JSON to write");
  profile::Profiler profiler(profile_config(o));
  const ProfileRun run = trace_program(o, profiler, o.quiet ? nullptr : &std::cerr);
  const nlohmann::json doc = workload_document(o, profiler, run);
  schemas.validate(doc, SchemaKind::Workload, o.out);
  write_file_atomic(o.out, doc.dump(2) + "\n");
  if (!o.slices_csv.empty()) {
    std::ostringstream csv;
    csv << "first_instruction,instructions,loads,stores,l1_refills,l1_writebacks,l2_refills,"
           "l2_writebacks";
    for (const std::uint64_t kb : profiler.capacities_kb())
      csv << ",l3_misses_" << kb << "kb";
    csv << "\n";
    std::uint64_t first = 0;
    for (const profile::SliceCounts& s : profiler.slices()) {
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
    const profile::SliceCounts t = profiler.total();
    char line[640];
    std::snprintf(
        line, sizeof line,
        "profile: %s: %llu instructions%s in %.1f s; loads %llu, stores %llu; "
        "L1 refills %.3f pki, L2 refills %.3f pki, L2 write-backs %.3f pki; "
        "footprint %.0f KB; %zu phases; CPU: valgrind %.1f s, profiler %.1f s "
        "(%.2f M instructions traced, skipped ones included, per CPU second)\n",
        o.out.c_str(), static_cast<unsigned long long>(profiler.instructions()),
        run.bounded ? " (bounded)" : "", run.wall_seconds, static_cast<unsigned long long>(t.loads),
        static_cast<unsigned long long>(t.stores), t.pki(t.l1_refills), t.pki(t.l2_refills),
        t.pki(t.l2_writebacks), doc["sim"]["footprint_kb"].get<double>(),
        doc["sim"]["phases"].size(), run.tracer_cpu_seconds, run.profiler_cpu_seconds,
        static_cast<double>(o.skip_instructions + profiler.instructions()) / 1e6 /
            std::max(1e-9, run.tracer_cpu_seconds + run.profiler_cpu_seconds));
    std::cerr << line;
  }
  return 0;
}

}  // namespace rosguard

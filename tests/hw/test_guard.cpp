// rosguard guard (hw/guard/guard.h, tools/rosguard/host/guard.cpp): a stress-ng process pinned on
// an nRT core is held to its budget while an RT node says it is active and runs freely otherwise;
// SIGTERM leaves no throttled core and no SCHED_FIFO thread; SIGHUP with a changed threshold takes
// effect from the next window while regulation goes on.
#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iterator>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "hw/common/clock.h"
#include "hw/common/sys.h"
#include "hw/guard/dds_guard.h"
#include "hw/guard/guard.h"
#include "hw_test_files.h"
#include "policy/builtin_registry.h"
#include "policy/policy.h"

using namespace rosguard;
using namespace rosguard::hw;
namespace fs = std::filesystem;
using rosguard::test::slurp;

namespace {

// Below this share of its core, unregulated, stress-ng shares the core with other work (other
// tests' SCHED_FIFO threads, builds): CPU-share comparisons then say nothing about the guard.
constexpr double kQuiet = 0.6;

bool have_stress_ng() {
  return ::access("/usr/bin/stress-ng", X_OK) == 0 && ::access("/usr/bin/taskset", X_OK) == 0;
}

// `taskset -c CORE stress-ng --cpu 1` in its own process group; killed with the group.
class Stress {
 public:
  // Pinned to `core`, or (core -1) not pinned, with `workers` workers.
  explicit Stress(int core, int workers = 1) {
    pid_ = ::fork();
    REQUIRE(pid_ >= 0);
    if (pid_ == 0) {
      ::setpgid(0, 0);
      const int null = ::open("/dev/null", O_WRONLY);
      ::dup2(null, 1);
      ::dup2(null, 2);
      const std::string c = std::to_string(core), w = std::to_string(workers);
      if (core < 0)
        ::execl("/usr/bin/stress-ng", "stress-ng", "--cpu", w.c_str(), "--cpu-method", "int64",
                "--timeout", "120s", static_cast<char*>(nullptr));
      else
        ::execl("/usr/bin/taskset", "taskset", "-c", c.c_str(), "/usr/bin/stress-ng", "--cpu",
                w.c_str(), "--cpu-method", "int64", "--timeout", "120s",
                static_cast<char*>(nullptr));
      ::_exit(127);
    }
    ::setpgid(pid_, pid_);
  }
  ~Stress() {
    ::kill(-pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
  }
  // CPU time (ns) of every thread in the process group so far.
  std::uint64_t cpu_ns() const { return cpu_ns_of(schedstats()); }
  // The CPU time (ns) the schedstat files `files` hold, summed (a thread gone counts 0).
  static std::uint64_t cpu_ns_of(const std::vector<fs::path>& files) {
    std::uint64_t total = 0;
    for (const auto& f : files)
      total += std::strtoull(slurp(f).c_str(), nullptr, 10);
    return total;
  }
  // The schedstat files of every thread in the process group now.
  std::vector<fs::path> schedstats() const {
    std::vector<fs::path> out;
    for (const auto& p :
         fs::directory_iterator("/proc", fs::directory_options::skip_permission_denied)) {
      const std::string name = p.path().filename();
      if (name.find_first_not_of("0123456789") != std::string::npos) continue;
      const std::string stat = slurp(p.path() / "stat");
      const auto close = stat.rfind(')');
      if (close == std::string::npos) continue;
      std::istringstream rest(stat.substr(close + 2));
      char state;
      long ppid, pgrp;
      rest >> state >> ppid >> pgrp;
      if (pgrp != pid_) continue;
      std::error_code ec;
      for (const auto& t : fs::directory_iterator(p.path() / "task", ec))
        out.push_back(t.path() / "schedstat");
    }
    return out;
  }
  // Share of one CPU the group got over `d`.
  double share(std::chrono::milliseconds d) const {
    const auto t0 = std::chrono::steady_clock::now();
    const std::uint64_t c0 = cpu_ns();
    std::this_thread::sleep_for(d);
    const std::uint64_t c1 = cpu_ns();
    const double wall =
        std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count();
    return static_cast<double>(c1 - c0) / wall;
  }
  // Every thread of the group under SCHED_OTHER (none left in SCHED_IDLE or elsewhere).
  bool all_sched_other() const {
    bool ok = true, any = false;
    for (const auto& p :
         fs::directory_iterator("/proc", fs::directory_options::skip_permission_denied)) {
      const std::string name = p.path().filename();
      if (name.find_first_not_of("0123456789") != std::string::npos) continue;
      if (::getpgid(std::stoi(name)) != pid_) continue;
      std::error_code ec;
      for (const auto& t : fs::directory_iterator(p.path() / "task", ec)) {
        any = true;
        ok = ok && ::sched_getscheduler(std::stoi(t.path().filename().string())) == SCHED_OTHER;
      }
    }
    return ok && any;
  }
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
};

GuardSettings settings_for(int ctl, int core, double threshold_pct,
                           const std::string& policy = "interval",
                           std::int64_t regulation_period_us = 10000) {
  GuardSettings s;
  s.name = "test";
  s.file = "test";
  s.controller_core = ctl;
  s.rt = {"planner"};
  s.nrt = {{"be", core}};
  RegulationSpec r;
  r.policy = policy;
  r.sampling = Sampling::External;
  r.sampling_period_us = 1000;
  r.regulation_period_us = regulation_period_us;
  r.threshold_pct = threshold_pct;
  r.reference_mbps = 1000.0;  // cputime: the budget is threshold_pct % of each window's time
  s.regulation = regulation_setup(r, {1, 1}, builtin_registry(), "test");
  s.rescan_ns = 50 * kNsPerMs;
  return s;
}

struct Recorder : GuardPublisher {
  std::string describe() const override { return "test recorder"; }
  void sample(const GuardSample& s) override { samples.push_back(s); }
  void command(const GuardCommandNote& c) override { commands.push_back(c); }
  void active(TimeNs, bool a) override { actives.push_back(a); }
  std::vector<GuardSample> samples;
  std::vector<GuardCommandNote> commands;
  std::vector<bool> actives;
};

// The stress-ng group's CPU time as the test read it (time, ns), once per serve() call. The
// group's threads are looked up in /proc every 20 readings only (a walk of /proc takes a few ms,
// a reading of their schedstat files a few us), so the trace costs the guard's thread little.
class CpuTrace {
 public:
  void read(const Stress& st) {
    if (points_.size() % 20 == 0) schedstats_ = st.schedstats();
    points_.emplace_back(now_ns(), Stress::cpu_ns_of(schedstats_));
  }
  const std::vector<std::pair<TimeNs, std::uint64_t>>& points() const { return points_; }

 private:
  std::vector<fs::path> schedstats_;
  std::vector<std::pair<TimeNs, std::uint64_t>> points_;
};

// Serves the guard for `d` on this thread (its main thread); with `st` and `trace`, reads the
// group's CPU time into the trace after each serve() call.
void serve_for(Guard& g, std::chrono::milliseconds d, const Stress* st = nullptr,
               CpuTrace* trace = nullptr) {
  const auto end = std::chrono::steady_clock::now() + d;
  while (std::chrono::steady_clock::now() < end) {
    g.serve(5 * kNsPerMs);
    if (st && trace) trace->read(*st);
  }
}

// Window by window (100 ms each) from the trace's start: what stress-ng ran as the test read it,
// what the guard's counter gained (ns of CPU time under the cputime source, shown in ms), and the
// commands it sent. A failure then shows whether the guard saw what stress-ng ran (a counter
// that falls behind: it reads other tasks) and whether its THR held the core (THR every window,
// stress-ng running anyway).
std::string timeline(const CpuTrace& cpu, const Recorder& rec) {
  const auto& trace = cpu.points();
  if (trace.size() < 2) return "no CPU-time trace";
  std::ostringstream out;
  out << std::fixed << std::setprecision(1);
  const TimeNs start = trace.front().first, bucket = 100 * kNsPerMs;
  const auto counter_at = [&](TimeNs t) {  // the guard's last reading at or before t
    double c = -1.0;
    for (const auto& s : rec.samples)
      if (s.t <= t) c = s.counter;
    return c;
  };
  std::size_t i = 0;
  for (TimeNs from = start; from < trace.back().first; from += bucket) {
    const TimeNs to = from + bucket;
    std::size_t j = i;
    while (j + 1 < trace.size() && trace[j + 1].first <= to)
      ++j;
    const double ran_ms = static_cast<double>(trace[j].second - trace[i].second) / 1e6;
    const double span_ms = static_cast<double>(trace[j].first - trace[i].first) / 1e6;
    int thr = 0, other = 0;
    for (const auto& c : rec.commands)
      if (c.t >= from && c.t < to) ++(c.command == Command::Thr ? thr : other);
    out << "  +" << (from - start) / kNsPerMs << " ms: stress-ng ran " << ran_ms << " of "
        << span_ms << " ms; guard counter +" << (counter_at(to) - counter_at(from)) / 1e6
        << " ms; THR " << thr << ", other commands " << other << "\n";
    i = j;
  }
  return out.str();
}

// How finely this kernel brings a running thread's CPU time (/proc/<tid>/schedstat, what the
// guard reads without a PMU) up to date, in ns: a child spins alone on `core` and its schedstat is
// read every 200 us for 40 ms from 10 ms in; the largest step between two readings. Where it
// is updated at the scheduler tick only (seen: 4 ms steps, HZ 250, on 6.18 under Firecracker), a
// budget is seen up to one step late. The child spins at SCHED_FIFO 1 where the host allows it:
// a busy process sharing the core would switch it out between ticks, and each switch brings its
// CPU time up to date (seen: a 0.26 ms step in a run beside a spinner, 4 ms without), so the step
// would be measured smaller than it is for a thread that keeps its core. It spins until it has
// been read (a reading after it ended would show no step), and the measurement is taken again
// where it never ran; 0 after 3 attempts.
long long cpu_time_step_ns(int core) {
  // The reader keeps off `core`: there the spinner at SCHED_FIFO would hold it off until the end,
  // and every reading would come after the spinner stopped (seen: steps of 0 in 4 of 17 hw-suite
  // passes).
  cpu_set_t saved, away;
  ::sched_getaffinity(0, sizeof saved, &saved);
  away = saved;
  CPU_CLR(core, &away);
  if (CPU_COUNT(&away) > 0) ::sched_setaffinity(0, sizeof away, &away);
  struct Restore {
    cpu_set_t& set;
    ~Restore() { ::sched_setaffinity(0, sizeof set, &set); }
  } restore{saved};
  for (int attempt = 0; attempt < 3; ++attempt) {
    const pid_t child = ::fork();
    if (child == 0) {
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      cpu_set_t set;
      CPU_ZERO(&set);
      CPU_SET(core, &set);
      ::sched_setaffinity(0, sizeof set, &set);
      const sched_param fifo{1};
      ::sched_setscheduler(0, SCHED_FIFO, &fifo);  // refused: spins as SCHED_OTHER
      // Until the parent has read it and kills it; 1 s at most.
      const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(1);
      while (std::chrono::steady_clock::now() < end) {
      }
      ::_exit(0);
    }
    const auto read_ns = [child] {
      std::ifstream f("/proc/" + std::to_string(child) + "/schedstat");
      long long ns = -1;
      f >> ns;
      return ns;
    };
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    const long long first = read_ns();
    long long last = first, step = 0;
    for (int i = 0; i < 200; ++i) {
      std::this_thread::sleep_for(std::chrono::microseconds(200));
      const long long now = read_ns();
      step = std::max(step, now - last);
      last = now;
    }
    ::kill(child, SIGKILL);
    ::waitpid(child, nullptr, 0);
    if (first >= 0 && last > first) return step;  // it ran: a measurement
  }
  return 0;  // the spinner never ran on the core (held by something above SCHED_FIFO 1)
}

double share_while_serving(Guard& g, const Stress& st, std::chrono::milliseconds d,
                           CpuTrace* trace = nullptr) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::uint64_t c0 = st.cpu_ns();
  serve_for(g, d, &st, trace);
  const std::uint64_t c1 = st.cpu_ns();
  const double wall =
      std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count();
  return static_cast<double>(c1 - c0) / wall;
}

}  // namespace

TEST_CASE("guard holds a pinned stress-ng to its budget while the RT node is active",
          "[hw][guard]") {
  const auto cpus = usable_cpus();
  if (!have_stress_ng() || cpus.size() < 2) {
    WARN("SKIPPED: needs stress-ng, taskset and two CPUs");
    return;
  }
  const int core = cpus.back(), ctl = cpus.front();
  const long long cpu_step_ns = cpu_time_step_ns(core);
  Stress st(core);
  InprocActivity activity;
  Recorder rec;
  std::ostringstream log;
  {
    Guard g(settings_for(ctl, core, 10.0), activity, rec, log);
    g.start();
    serve_for(g, std::chrono::milliseconds(300));  // a rescan finds stress-ng
    const double before = share_while_serving(g, st, std::chrono::milliseconds(500));
    activity.signal(0, true);
    serve_for(g, std::chrono::milliseconds(50));
    CpuTrace trace;
    const double active = share_while_serving(g, st, std::chrono::milliseconds(1000), &trace);
    activity.signal(0, false);
    serve_for(g, std::chrono::milliseconds(50));
    const double after = share_while_serving(g, st, std::chrono::milliseconds(500));
    INFO(log.str());
    INFO("while active:\n" << timeline(trace, rec));
    INFO("CPU share of stress-ng: before " << before << ", active " << active << ", after " << after
                                           << "; throttle " << to_string(g.throttle().kind));
    CHECK_THAT(log.str(), Catch::Contains("regulating pid " + std::to_string(st.pid())) ||
                              Catch::Contains("(stress-ng"));
    CHECK(g.stats().throttles > 10);
    CHECK(g.stats().activations == 1);
    // Budget: 10 % of each 10 ms window, plus one sampling period of overshoot and the
    // activation delay; far below what it gets unregulated.
    if (before < kQuiet) {
      WARN("SKIPPED (CPU shares): other work held the core (stress-ng got "
           << before << " of it unregulated)");
    } else {
      INFO("the kernel updates a running thread's CPU time in steps of up to " << cpu_step_ns / 1000
                                                                               << " us");
      // ... plus one step of the CPU-time clock the budget is read from (a budget is seen up to
      // one step late).
      if (cpu_step_ns > 0)
        CHECK(active < 0.35 + static_cast<double>(cpu_step_ns) / (10.0 * kNsPerMs));
      else
        WARN(
            "SKIPPED (budget bound): the CPU-time step could not be measured (a spinner at "
            "SCHED_FIFO 1 never ran on CPU "
            << core << " in 3 attempts)");
      // Regulation held back a clear part, a quarter, of what stress-ng gets unregulated. (The
      // budget bound above is the precise claim; half was asked here before, and failed 3 of 27
      // idle runs on a host that took time from the vCPUs: 0.53 after 0.98, 0.39 after 0.77, both
      // within the bound. A guard that does not regulate leaves stress-ng its whole share.)
      CHECK(active < 0.75 * before);
      // Released, it regains at least half of what regulation held back (not twice its regulated
      // share: in CI on 2026-11-28 a host that took time from the vCPU left it 0.70 after 0.37).
      CHECK(after - active > 0.5 * (before - active));
    }
    REQUIRE_FALSE(rec.samples.empty());
    CHECK(rec.samples.back().budget_bytes == Approx(0.10 * 1000.0 * 1048576.0 * 0.010));
    g.shutdown();
  }
  CHECK(realtime_threads().empty());
  CHECK(st.all_sched_other());
  CHECK_THAT(log.str(), Catch::Contains("stopped: 1 core(s) back to nominal") &&
                            Catch::Contains("0 thread(s) left under SCHED_FIFO"));
}

TEST_CASE(
    "guard, cputime source: a pinned stress-ng gets at most its budget plus one sampling period "
    "and the throttle's activation per window, at 2, 10 and 50 %",
    "[hw][guard]") {
  const auto cpus = usable_cpus();
  if (!have_stress_ng() || cpus.size() < 2) {
    WARN("SKIPPED: needs stress-ng, taskset and two CPUs");
    return;
  }
  const int core = cpus.back(), ctl = cpus.front();
  const long long cpu_step_ns = cpu_time_step_ns(core);
  Stress st(core);
  for (const double pct : {2.0, 10.0, 50.0}) {
    InprocActivity activity;
    Recorder rec;
    std::ostringstream log;
    GuardSettings s = settings_for(ctl, core, pct, "interval", 5000);
    s.source = GuardSource::Cputime;
    Guard g(s, activity, rec, log);
    g.start();
    serve_for(g, std::chrono::milliseconds(300));  // a rescan finds stress-ng
    const double before = share_while_serving(g, st, std::chrono::milliseconds(300));
    activity.signal(0, true);
    serve_for(g, std::chrono::milliseconds(50));
    const double active = share_while_serving(g, st, std::chrono::milliseconds(1500));
    activity.signal(0, false);
    serve_for(g, std::chrono::milliseconds(50));
    double activation_us = 0.0;
    for (const auto& m : g.throttle().measured)
      if (m.kind == g.throttle().kind) activation_us = m.activation_us;
    g.shutdown();
    // The documented bound (docs/guard.md): per 5 ms window the budget, one 1 ms sampling period
    // and the throttle's activation delay as the guard measured it at start; where no perf task
    // clock opens (the schedstat fallback), one step of that clock more.
    double bound = pct / 100.0 + (1000.0 + activation_us) / 5000.0;
    if (log.str().find("fallback (cputime)") != std::string::npos)
      bound += static_cast<double>(cpu_step_ns) / (5.0 * kNsPerMs);
    INFO(log.str());
    INFO("threshold " << pct << " %: stress-ng's share " << active << " (unregulated " << before
                      << "), bound " << bound << " (activation " << activation_us << " us)");
    CHECK_THAT(log.str(),
               Catch::Contains("perf task clock") || Catch::Contains("fallback (cputime)"));
    CHECK(g.stats().throttles > 10);
    CHECK(active <= bound);
    if (before < kQuiet)
      WARN("other work held the core (stress-ng got " << before << " of it unregulated)");
  }
}

TEST_CASE(
    "guard runs every policy tune can choose: monolithic throttles once per RT execution, "
    "memguard and mempol every window",
    "[hw][guard]") {
  const auto cpus = usable_cpus();
  if (!have_stress_ng() || cpus.size() < 2) {
    WARN("SKIPPED: needs stress-ng, taskset and two CPUs");
    return;
  }
  const int core = cpus.back(), ctl = cpus.front();
  Stress st(core);
  for (const std::string policy : {"monolithic", "memguard", "mempol"}) {
    InprocActivity activity;
    Recorder rec;
    std::ostringstream log;
    GuardSettings s = settings_for(ctl, core, 10.0, policy);
    s.source = GuardSource::Cputime;
    // monolithic: 10 % of a 100 ms RT execution, 10 ms of CPU time, spent early in each 400 ms
    // activation.
    s.regulation.params.monolithic_window_ns = 100 * kNsPerMs;
    Guard g(s, activity, rec, log);
    g.start();
    serve_for(g, std::chrono::milliseconds(300));  // a rescan finds stress-ng
    for (int job = 0; job < 2; ++job) {
      activity.signal(0, true);
      serve_for(g, std::chrono::milliseconds(400));
      activity.signal(0, false);
      serve_for(g, std::chrono::milliseconds(100));
    }
    g.shutdown();
    INFO(policy << ":\n" << log.str());
    CHECK_THAT(log.str(),
               Catch::Contains("regulating be (CPU " + std::to_string(core) + ") with " + policy));
    CHECK(g.stats().activations == 2);
    if (policy == "monolithic")
      CHECK(g.stats().throttles == 2);
    else
      CHECK(g.stats().throttles > 20);  // 10 ms windows, 800 ms active
  }
  CHECK(st.all_sched_other());
}

TEST_CASE("rosguard guard --check: monolithic needs rt_window_us, and no other policy takes it",
          "[hw][guard][cli]") {
  const fs::path dir =
      fs::temp_directory_path() / ("rosguard-guard-window-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const auto check = [&](const nlohmann::json& regulation) {
    const nlohmann::json doc = {{"name", "window"},
                                {"controller", {{"core", 0}}},
                                {"rt", {{{"name", "planner"}}}},
                                {"nrt", {{{"name", "be"}, {"core", 1}}}},
                                {"regulation", regulation}};
    std::ofstream(dir / "guard.json") << doc.dump(2);
    const std::string cmd =
        std::string(ROSGUARD_BINARY) + " guard " + (dir / "guard.json").string() + " --check 2>&1";
    FILE* p = ::popen(cmd.c_str(), "r");
    REQUIRE(p);
    std::string out;
    char buf[4096];
    for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, p)) > 0;)
      out.append(buf, n);
    return std::make_pair(WEXITSTATUS(::pclose(p)), out);
  };
  const nlohmann::json base = {{"threshold_pct", 10}, {"reference_mbps", 1000}};
  auto r = base;
  r["policy"] = "monolithic";
  const auto [no_window, said] = check(r);
  CHECK(no_window == 2);
  CHECK_THAT(said, Catch::Contains("/regulation/rt_window_us") &&
                       Catch::Contains("policy \"monolithic\" needs"));
  r["rt_window_us"] = 120000;
  const auto [with_window, printed] = check(r);
  CHECK(with_window == 0);
  CHECK_THAT(printed, Catch::Contains("\"rt_window_us\": 120000"));
  r["policy"] = "memguard";
  const auto [other, refused] = check(r);
  CHECK(other == 2);
  CHECK_THAT(refused, Catch::Contains("only policy \"monolithic\" uses rt_window_us"));
  fs::remove_all(dir);
}

TEST_CASE(
    "guard pin_processes: an unpinned 4-worker stress-ng is pinned to the nRT core, regulated "
    "there (THR per core in the log) and given its affinity back",
    "[hw][guard]") {
  const auto cpus = usable_cpus();
  if (!have_stress_ng() || cpus.size() < 2) {
    WARN("SKIPPED: needs stress-ng and two CPUs");
    return;
  }
  const int core = cpus.back(), ctl = cpus.front();
  Stress st(-1, 4);
  InprocActivity activity;
  Recorder rec;
  std::ostringstream log;
  {
    GuardSettings s = settings_for(ctl, core, 10.0);
    s.source = GuardSource::Cputime;
    s.pin_processes = {"stress-ng", "stress-ng-cpu"};
    Guard g(s, activity, rec, log);
    g.start();
    serve_for(g, std::chrono::milliseconds(300));  // the workers are up and found
    activity.signal(0, true);
    serve_for(g, std::chrono::milliseconds(500));
    activity.signal(0, false);
    serve_for(g, std::chrono::milliseconds(50));
    g.shutdown();
    INFO(log.str());
    // This stress-ng's workers (not those of another one still exiting).
    std::size_t pinned = 0;
    for (const auto& f : st.schedstats())
      if (log.str().find("tid " + f.parent_path().filename().string() +
                         " (stress-ng-cpu): pinned to CPU " + std::to_string(core)) !=
          std::string::npos)
        ++pinned;
    CHECK(pinned == 4);
    CHECK(g.stats().throttles > 10);
    REQUIRE(g.stats().core_throttles.size() == 1);
    CHECK(g.stats().core_throttles[0] == g.stats().throttles);
    CHECK_THAT(log.str(), Catch::Contains("THR command(s) (be (CPU " + std::to_string(core) + ") " +
                                          std::to_string(g.stats().throttles) + ")"));
  }
  // Every thread has its affinity back: all of this host's CPUs, as stress-ng started.
  std::size_t threads = 0;
  for (const auto& f : st.schedstats()) {
    const pid_t tid = static_cast<pid_t>(std::stol(f.parent_path().filename().string()));
    cpu_set_t set;
    CPU_ZERO(&set);
    if (::sched_getaffinity(tid, sizeof set, &set) != 0) continue;
    ++threads;
    CHECK(CPU_COUNT(&set) == static_cast<int>(cpus.size()));
  }
  CHECK(threads >= 5);
}

TEST_CASE("guard log: every activation's end is a line of its own, with its THR per core",
          "[hw][guard]") {
  const auto cpus = usable_cpus();
  if (!have_stress_ng() || cpus.size() < 2) {
    WARN("SKIPPED: needs stress-ng, taskset and two CPUs");
    return;
  }
  const int core = cpus.back(), ctl = cpus.front();
  Stress st(core);
  InprocActivity activity;
  Recorder rec;
  std::ostringstream log;
  Guard g(settings_for(ctl, core, 10.0), activity, rec, log);
  g.start();
  serve_for(g, std::chrono::milliseconds(300));  // a rescan finds stress-ng
  // Five jobs of 100 ms within a second: far inside the 10 s in which repeated lines fold.
  for (int job = 0; job < 5; ++job) {
    activity.signal(0, true);
    serve_for(g, std::chrono::milliseconds(100));
    activity.signal(0, false);
    serve_for(g, std::chrono::milliseconds(50));
  }
  g.shutdown();
  INFO(log.str());
  CHECK(g.stats().activations == 5);
  std::istringstream lines(log.str());
  std::uint64_t thr = 0;
  int ends = 0;
  for (std::string line; std::getline(lines, line);) {
    const auto at = line.find("regulation inactive (every RT node finished): activation ");
    if (at == std::string::npos) continue;
    ++ends;
    CHECK_THAT(line, Catch::Contains("activation " + std::to_string(ends) + " lasted "));
    // "... ms, N THR (nrt0 N)": the one core's count is the total.
    const auto total = line.find(" THR (");
    REQUIRE(total != std::string::npos);
    const std::uint64_t n = std::stoull(line.substr(line.rfind(' ', total - 1) + 1));
    CHECK_THAT(line, Catch::EndsWith(" " + std::to_string(n) + ")"));
    thr += n;
  }
  CHECK(ends == 5);
  CHECK(thr == g.stats().throttles);
  CHECK_THAT(log.str(), !Catch::Contains("more of 'regulation inactive'"));
}

TEST_CASE("guard reload: a new threshold from the next window, regulation never pauses",
          "[hw][guard][reload]") {
  const auto cpus = usable_cpus();
  if (!have_stress_ng() || cpus.size() < 2) {
    WARN("SKIPPED: needs stress-ng, taskset and two CPUs");
    return;
  }
  const int core = cpus.back(), ctl = cpus.front();
  Stress st(core);
  InprocActivity activity;
  Recorder rec;
  std::ostringstream log;
  Guard g(settings_for(ctl, core, 50.0), activity, rec, log);
  g.start();
  serve_for(g, std::chrono::milliseconds(300));
  const double free = share_while_serving(g, st, std::chrono::milliseconds(400));
  activity.signal(0, true);
  CpuTrace trace;
  const double at50 = share_while_serving(g, st, std::chrono::milliseconds(800), &trace);
  const std::size_t before = rec.samples.size();
  REQUIRE(g.reload(settings_for(ctl, core, 5.0)));
  const double at5 = share_while_serving(g, st, std::chrono::milliseconds(800), &trace);
  activity.signal(0, false);
  serve_for(g, std::chrono::milliseconds(50));
  g.shutdown();
  INFO(log.str());
  INFO("at 50 %, then at 5 % from the reload:\n" << timeline(trace, rec));
  INFO("CPU share unregulated: " << free << ", at 50 %: " << at50 << ", at 5 %: " << at5);
  if (free < kQuiet)
    WARN("SKIPPED (CPU shares): other work held the core (stress-ng got " << free
                                                                          << " of it unregulated)");
  else
    CHECK(at5 < 0.6 * at50);
  // The budget in the samples goes from 50 % to 5 % of the window, with no sample in between
  // that saw regulation off, and samples kept coming through the reload.
  const double b50 = 0.50 * 1000.0 * 1048576.0 * 0.010, b5 = 0.05 * 1000.0 * 1048576.0 * 0.010;
  REQUIRE(rec.samples.size() > before + 100);
  CHECK(rec.samples[before - 1].budget_bytes == Approx(b50));
  CHECK(rec.samples.back().budget_bytes == Approx(b5));
  bool switched = false;
  TimeNs at_switch = -1, longest = 0;
  for (std::size_t i = before; i < rec.samples.size(); ++i) {
    const double b = rec.samples[i].budget_bytes;
    CHECK((b == Approx(b50) || b == Approx(b5)));
    if (switched) CHECK(b == Approx(b5));  // never back
    const TimeNs gap = rec.samples[i].t - rec.samples[i - 1].t;
    if (!switched && b == Approx(b5)) at_switch = gap;
    switched = switched || b == Approx(b5);
    longest = std::max(longest, gap);
  }
  CHECK(switched);
  // The reload does not pause sampling: the last sample under the old budget and the first under
  // the new one are less than one 10 ms window apart. (Elsewhere a gap may be longer without the
  // guard pausing: its sampler is a SCHED_FIFO thread, and RT throttling takes 50 ms of a second
  // from a core whose real-time threads used the rest, which other tests running beside this one
  // can do; one pass of the hw suite in 8 saw a 10.7 ms gap.)
  INFO("gap at the switch " << at_switch << " ns, longest gap after the reload " << longest
                            << " ns");
  CHECK(at_switch >= 0);
  CHECK(at_switch < 10 * kNsPerMs);
  CHECK(std::count(rec.actives.begin(), rec.actives.end(), false) == 1);  // only at the end
  CHECK_THAT(log.str(), Catch::Contains("reload: threshold_pct 50 -> 5") &&
                            Catch::Contains("new policy parameters in force from the next window"));
  // A change that cannot be applied while running is refused, and the guard keeps going.
  auto other = settings_for(ctl, core, 5.0, "monitor");
  CHECK_FALSE(g.reload(other));
}

TEST_CASE("rosguard guard: SIGHUP reloads, SIGTERM leaves no throttled core and no FIFO thread",
          "[hw][guard][cli]") {
  const auto cpus = usable_cpus();
  if (!have_stress_ng() || cpus.size() < 2) {
    WARN("SKIPPED: needs stress-ng, taskset and two CPUs");
    return;
  }
  const int core = cpus.back(), ctl = cpus.front();
  const fs::path dir = fs::temp_directory_path() / ("rosguard-guard-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const auto config = [&](double threshold) {
    nlohmann::json doc = {{"name", "cli"},
                          {"controller", {{"core", ctl}}},
                          {"rt", {{{"name", "planner"}}}},
                          {"nrt", {{{"name", "be"}, {"core", core}}}},
                          {"regulation",
                           {{"policy", "interval"},
                            {"sampling_period_us", 1000},
                            {"regulation_period_us", 10000},
                            {"threshold_pct", threshold},
                            {"reference_mbps", 1000}}},
                          {"hw", {{"rescan_ms", 50}}},
                          {"activity", {{"source", "fifo"}, {"path", (dir / "activity").string()}}},
                          {"publish", {{"transport", "none"}}}};
    std::ofstream(dir / "guard.json.tmp") << doc.dump(2);
    fs::rename(dir / "guard.json.tmp", dir / "guard.json");
  };
  config(50.0);
  Stress st(core);
  const fs::path err = dir / "stderr";
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    const int fd = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(fd, 2);
    ::setenv("ROSGUARD_HOME", ROSGUARD_TEST_SOURCE_DIR, 1);
    ::execl(ROSGUARD_BINARY, "rosguard", "guard", (dir / "guard.json").c_str(),
            static_cast<char*>(nullptr));
    ::_exit(127);
  }
  const auto wait_for = [&](const std::string& text, int seconds) {
    for (int i = 0; i < seconds * 20; ++i) {
      if (slurp(err).find(text) != std::string::npos) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return false;
  };
  REQUIRE(wait_for("regulating be (CPU", 20));
  REQUIRE(wait_for("regulating pid", 5));
  const double free = st.share(std::chrono::milliseconds(400));
  { std::ofstream(dir / "activity") << "planner 1\n"; }
  CHECK(wait_for("regulation active", 5));
  CHECK(wait_for("-> THR", 5));
  const double at50 = st.share(std::chrono::milliseconds(600));
  config(5.0);
  ::kill(pid, SIGHUP);
  CHECK(wait_for("reload: threshold_pct 50 -> 5", 5));
  CHECK(wait_for("new policy parameters in force from the next window", 5));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  const double at5 = st.share(std::chrono::milliseconds(600));
  // A line the activity pipe cannot read, and a file that no longer validates: both refused,
  // logged, and the guard keeps going.
  { std::ofstream(dir / "activity") << "planner maybe\n"; }
  CHECK(wait_for("ignored activity line 'planner maybe'", 5));
  { std::ofstream(dir / "guard.json") << "{ \"name\": 7 }"; }
  ::kill(pid, SIGHUP);
  CHECK(wait_for("reload refused: ", 5));
  // Still regulating (the RT node is active) when stopped: SIGTERM must release the core.
  ::kill(pid, SIGTERM);
  int status = 0;
  REQUIRE(::waitpid(pid, &status, 0) == pid);
  const std::string text = slurp(err);
  INFO(text);
  INFO("CPU share unregulated: " << free << ", at 50 %: " << at50 << ", at 5 %: " << at5);
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 0);
  const bool quiet = free >= kQuiet;
  if (!quiet)
    WARN("SKIPPED (CPU shares): other work held the core (stress-ng got " << free
                                                                          << " of it unregulated)");
  if (quiet) CHECK(at5 < 0.6 * at50);
  CHECK_THAT(text, Catch::Contains("SIGTERM received") &&
                       Catch::Contains("stopped: 1 core(s) back to nominal") &&
                       Catch::Contains("0 thread(s) left under SCHED_FIFO"));
  CHECK_THAT(text, !Catch::Contains("regulation inactive"));  // no gap across the reload
  // Every line in one form: an ISO time stamp, the guard's name, the text.
  std::istringstream lines(text);
  for (std::string l; std::getline(lines, l);) {
    INFO("log line: " << l);
    CHECK(l.size() > 25);
    CHECK(l.compare(4, 1, "-") == 0);
    CHECK(l.compare(10, 1, "T") == 0);
    CHECK(l.find("Z guard cli: ") != std::string::npos);
  }
  // Nothing of the guard is left: no thread anywhere named after its core's callbacks, and the
  // core runs stress-ng freely again, under its own scheduling.
  for (const auto& p :
       fs::directory_iterator("/proc", fs::directory_options::skip_permission_denied)) {
    const std::string name = p.path().filename();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::error_code ec;
    for (const auto& t : fs::directory_iterator(p.path() / "task", ec)) {
      const std::string comm = slurp(t.path() / "comm");
      CHECK(comm.rfind("be-thr", 0) != 0);
      CHECK(comm.rfind("be-cfb", 0) != 0);
    }
  }
  if (quiet) CHECK(st.share(std::chrono::milliseconds(400)) > 2.0 * at5);
  CHECK(st.all_sched_other());
  fs::remove_all(dir);
}

TEST_CASE("guard over DDS: Bool activity in, samples (with budgets) and commands out, ROS 2 names",
          "[hw][guard][dds]") {
  const auto cpus = usable_cpus();
  if (!have_stress_ng() || cpus.size() < 2) {
    WARN("SKIPPED: needs stress-ng, taskset and two CPUs");
    return;
  }
  const std::string uri =
      std::string("file://") + ROSGUARD_TEST_SOURCE_DIR + "/tests/hw/cyclonedds-loopback.xml";
  ::setenv("CYCLONEDDS_URI", uri.c_str(), 1);
  const std::string ns = "/guard_test_" + std::to_string(::getpid());
  const int core = cpus.back(), ctl = cpus.front();
  Stress st(core);
  dds::Participant guard_participant(std::nullopt, nullptr,
                                     dds::RosNode{dds::rosguard_node_namespace(ns), "guard_test"});
  DdsActivity activity(guard_participant, ns, false);
  DdsPublisher publisher(guard_participant, {"be"}, ns);
  // Plain Cyclone endpoints with the ROS 2 names, as an RT node and a `ros2 topic echo` would use.
  dds::Participant outside;
  dds::Writer<dds::BoolMsg> rt(outside, ns + "/rosguard/planner/active");
  dds::Reader<dds::PmcSampleMsg> pmc(outside, ns + "/rosguard/be/pmc");
  dds::Reader<dds::CommandMsg> cmd(outside, ns + "/rosguard/be/command");
  CHECK(dds::dds_topic_name(ns + "/rosguard/be/pmc") == "rt" + ns + "/rosguard/be/pmc");
  std::ostringstream log;
  Guard g(settings_for(ctl, core, 10.0), activity, publisher, log);
  g.start();
  // Wait for discovery both ways (volatile topics keep nothing for late joiners).
  for (int i = 0; i < 200 && (rt.matched() == 0 || pmc.matched() == 0 || cmd.matched() == 0); ++i)
    serve_for(g, std::chrono::milliseconds(10));
  REQUIRE(rt.matched() > 0);
  REQUIRE(pmc.matched() > 0);
  std::size_t samples = 0, thr = 0;
  double budget = 0.0;
  // Keep-last 10 (ROS 2's default depth): take as they come, as a subscriber does.
  const auto drain = [&] {
    dds::PmcSampleMsg s{};
    while (pmc.take(s)) {
      ++samples;
      CHECK(s.count == 3);
      CHECK(s.entity == 0u);
      budget = static_cast<double>(s.value[2]);
    }
    dds::CommandMsg c{};
    while (cmd.take(c))
      thr += c.command == dds::command::kThr ? 1 : 0;
  };
  dds::BoolMsg on{true};
  rt.write(on);
  for (int i = 0; i < 100; ++i) {
    serve_for(g, std::chrono::milliseconds(5));
    drain();
  }
  dds::BoolMsg off{false};
  rt.write(off);
  for (int i = 0; i < 20; ++i) {
    serve_for(g, std::chrono::milliseconds(5));
    drain();
  }
  INFO(log.str());
  CHECK(g.stats().activations == 1);
  CHECK(g.stats().throttles > 5);
  CHECK(samples > 100);  // 1 kHz sampling for 0.5 s
  CHECK(budget == Approx(0.10 * 1000.0 * 1048576.0 * 0.010).epsilon(1e-6));
  CHECK(thr == g.stats().throttles);
  g.shutdown();
  CHECK(realtime_threads().empty());
}

TEST_CASE("rosguard guard --help gives the guard's own examples, not the quickstart's",
          "[hw][guard][cli]") {
  std::string out;
  FILE* p = ::popen(ROSGUARD_BINARY " guard --help 2>&1", "r");
  REQUIRE(p);
  char buf[4096];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, p)) > 0;)
    out.append(buf, n);
  CHECK(::pclose(p) == 0);
  INFO(out);
  CHECK_THAT(out, Catch::Contains("rosguard guard docs/guard/example.json --check") &&
                      Catch::Contains("rosguard guard /etc/rosguard/guard.json") &&
                      Catch::Contains("kill -HUP") && Catch::Contains("docs/guard.md") &&
                      !Catch::Contains("Start here") && !Catch::Contains("quickstart"));
}

TEST_CASE(
    "rosguard guard --check: a valid file with a core this host lacks is printed, with a "
    "warning that the guard would refuse to start here",
    "[hw][guard][cli]") {
  const auto cpus = usable_cpus();
  const int missing = cpus.back() + 1;
  const fs::path dir =
      fs::temp_directory_path() / ("rosguard-guard-check-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const nlohmann::json doc = {{"name", "elsewhere"},
                              {"controller", {{"core", cpus.front()}}},
                              {"rt", {{{"name", "planner"}}}},
                              {"nrt", {{{"name", "be"}, {"core", missing}}}},
                              {"regulation", {{"threshold_pct", 10}, {"reference_mbps", 1000}}}};
  std::ofstream(dir / "guard.json") << doc.dump(2);
  const std::string cmd = std::string(ROSGUARD_BINARY) + " guard " + (dir / "guard.json").string() +
                          " --check 2>" + (dir / "err").string();
  FILE* p = ::popen(cmd.c_str(), "r");
  REQUIRE(p);
  std::string out;
  char buf[4096];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, p)) > 0;)
    out.append(buf, n);
  const int status = ::pclose(p);
  std::ifstream in(dir / "err");
  const std::string err((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  fs::remove_all(dir);
  INFO(out << err);
  CHECK(WEXITSTATUS(status) == 0);
  CHECK(nlohmann::json::parse(out).at("nrt").at(0).at("core") == missing);
  CHECK_THAT(err, Catch::Contains("warning: ") &&
                      Catch::Contains("/nrt/0/core: core " + std::to_string(missing) +
                                      " is not usable on this host") &&
                      Catch::Contains("the guard would refuse to start on this host"));
}

#include "hw/throttle/throttle.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <thread>

#include "core/error.h"
#include "hw/common/clock.h"
#include "hw/common/sys.h"

namespace rosguard::hw {
namespace {

namespace fs = std::filesystem;

// The cgroup v2 mount point (the unified hierarchy, also in hybrid setups), or empty.
std::string cgroup2_mount() {
  std::ifstream in("/proc/self/mountinfo");
  std::string line;
  while (std::getline(in, line)) {
    // "... mount_point options ... - fstype source super_options"
    const auto dash = line.find(" - ");
    if (dash == std::string::npos) continue;
    std::istringstream tail(line.substr(dash + 3));
    std::string fstype;
    tail >> fstype;
    if (fstype != "cgroup2") continue;
    std::istringstream head(line.substr(0, dash));
    std::string id, parent, devno, root, mount;
    head >> id >> parent >> devno >> root >> mount;
    return mount;
  }
  return {};
}

// This process's cgroup v2 path ("0::/path"), or empty.
std::string own_cgroup() {
  std::ifstream in("/proc/self/cgroup");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("0::", 0) == 0) return line.substr(3);
  return {};
}

bool pid_alive(long pid) {
  return ::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM;
}

// Empty cgroups a dead rosguard left behind ("rosguard-<pid>-..."): rmdir removes only empty ones.
void remove_stale(const std::string& dir) {
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string n = e.path().filename().string();
    if (n.rfind("rosguard-", 0) != 0) continue;
    const long pid = std::strtol(n.c_str() + 9, nullptr, 10);
    if (pid > 0 && !pid_alive(pid)) ::rmdir(e.path().c_str());
  }
}

bool write_file(const std::string& path, const std::string& text, int* err) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) {
    if (err) *err = errno;
    return false;
  }
  const ssize_t n = ::write(fd, text.data(), text.size());
  const int e = errno;
  ::close(fd);
  if (n != static_cast<ssize_t>(text.size())) {
    if (err) *err = n < 0 ? e : EIO;
    return false;
  }
  return true;
}

class SpinThrottler : public Throttler {
 public:
  explicit SpinThrottler(ThrottleKind k) : kind_(k) {}
  ThrottleKind kind() const override { return kind_; }
  void hold(const std::function<bool()>& held, Waker&) override {
    while (held())
      cpu_relax();
  }

 private:
  ThrottleKind kind_;
};

class FreezeThrottler : public Throttler {
 public:
  explicit FreezeThrottler(FreezerCgroup& cg) : cg_(cg) {}
  ThrottleKind kind() const override { return ThrottleKind::Freezer; }
  void hold(const std::function<bool()>& held, Waker& wake) override {
    if (!cg_.freeze()) {
      // Frozen nothing: hold the core by spinning, as idle does, rather than not at all.
      while (held())
        cpu_relax();
      return;
    }
    while (true) {
      const auto e = wake.epoch();
      if (!held()) break;
      wake.wait(e, -1);
    }
    cg_.thaw();
  }

 private:
  FreezerCgroup& cg_;
};

// A worker process pinned to a core that counts loop iterations into a shared page, and its own
// CPU time (at most ~50 us old) beside them; SIGKILLed and reaped on destruction (and by the
// kernel if we die first). Its CPU time comes from itself because another process's CPU clock
// lags while it runs: the kernel brings a running task's time up to date only at scheduler ticks
// and switches, so a 10 ms window that begins as the worker resumes (time exact) and ends while
// it runs (half a tick behind on average) read some 20 % low on a 250 Hz kernel.
class Worker {
 public:
  Worker(int core, bool idle) {
    void* p = ::mmap(nullptr, 4096, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
    if (p == MAP_FAILED) throw RunError("mmap: " + errno_text(errno));
    counter_ = new (p) std::atomic<std::uint64_t>(0);
    cpu_ = new (counter_ + 1) std::atomic<std::int64_t>(0);
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(core, &set);
    const pid_t parent = ::getpid();
    pid_ = ::fork();
    if (pid_ < 0) {
      const int e = errno;
      ::munmap(p, 4096);
      throw RunError("fork: " + errno_text(e));
    }
    if (pid_ == 0) {  // async-signal-safe calls only
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (::getppid() != parent) ::_exit(0);
      ::sched_setaffinity(0, sizeof set, &set);
      const sched_param zero{};
      if (idle) {
        ::sched_setscheduler(0, SCHED_IDLE, &zero);
      } else {
        ::sched_setscheduler(0, SCHED_OTHER, &zero);
        ::setpriority(PRIO_PROCESS, 0, 0);
      }
      timespec ts{};
      std::int64_t published = 0;
      for (std::uint64_t n = 1;; ++n) {
        counter_->fetch_add(1, std::memory_order_relaxed);
        if ((n & 1023) != 0) continue;
        ::clock_gettime(CLOCK_MONOTONIC, &ts);  // vDSO: cheap
        const std::int64_t now = ts.tv_sec * kNsPerS + ts.tv_nsec;
        if (now - published < 50 * kNsPerUs) continue;
        published = now;
        ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);  // a system call: every 50 us at most
        cpu_->store(ts.tv_sec * kNsPerS + ts.tv_nsec, std::memory_order_relaxed);
      }
    }
  }
  ~Worker() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      while (::waitpid(pid_, nullptr, 0) < 0 && errno == EINTR) {
      }
    }
    ::munmap(static_cast<void*>(counter_), 4096);
  }
  Worker(const Worker&) = delete;
  Worker& operator=(const Worker&) = delete;
  pid_t pid() const { return pid_; }
  std::uint64_t count() const { return counter_->load(std::memory_order_relaxed); }
  TimeNs cpu_ns() const { return cpu_->load(std::memory_order_relaxed); }

 private:
  std::atomic<std::uint64_t>* counter_ = nullptr;
  std::atomic<std::int64_t>* cpu_ = nullptr;  // beside the counter in the shared page
  pid_t pid_ = -1;
};

}  // namespace

std::string_view to_string(ThrottleKind k) {
  switch (k) {
    case ThrottleKind::Fifo:
      return "fifo";
    case ThrottleKind::Idle:
      return "idle";
    case ThrottleKind::Freezer:
      return "freezer";
  }
  return "fifo";
}

std::optional<std::string> freezer_root(std::string* why) {
  const auto fail = [&](std::string w) -> std::optional<std::string> {
    if (why) *why = std::move(w);
    return std::nullopt;
  };
  std::string dir;
  if (const char* env = std::getenv("ROSGUARD_CGROUP"); env && *env) {
    dir = env;
  } else {
    const std::string mount = cgroup2_mount();
    if (mount.empty()) return fail("no cgroup v2 hierarchy is mounted (/proc/self/mountinfo)");
    const std::string own = own_cgroup();
    if (own.empty()) return fail("this process is in no cgroup v2 (/proc/self/cgroup has no 0::)");
    dir = mount + (own == "/" ? "" : own);
  }
  if (::access((dir + "/cgroup.procs").c_str(), W_OK) != 0)
    return fail(dir + "/cgroup.procs is not writable (" + errno_text(errno) +
                "): moving processes needs root or a delegated cgroup (ROSGUARD_CGROUP)");
  remove_stale(dir);
  const std::string probe = dir + "/rosguard-" + std::to_string(::getpid()) + "-probe";
  if (::mkdir(probe.c_str(), 0755) != 0 && errno != EEXIST)
    return fail("cannot create a cgroup in " + dir + ": " + errno_text(errno));
  const bool has_freeze = ::access((probe + "/cgroup.freeze").c_str(), W_OK) == 0;
  const int access_err = errno;
  ::rmdir(probe.c_str());
  if (!has_freeze)
    return fail(probe + "/cgroup.freeze is missing or not writable (" + errno_text(access_err) +
                "): the kernel has no cgroup v2 freezer (Linux 5.2+)");
  return dir;
}

FreezerCgroup::FreezerCgroup(const std::string& root, const std::string& name)
    : path_(root + "/" + name) {
  if (::mkdir(path_.c_str(), 0755) != 0 && errno != EEXIST)
    throw RunError("cannot create cgroup " + path_ + ": " + errno_text(errno));
  freeze_fd_ = ::open((path_ + "/cgroup.freeze").c_str(), O_WRONLY | O_CLOEXEC);
  if (freeze_fd_ < 0) {
    const int e = errno;
    ::rmdir(path_.c_str());
    throw RunError("cannot open " + path_ + "/cgroup.freeze: " + errno_text(e));
  }
  home_ = root + "/cgroup.procs";
}

FreezerCgroup::~FreezerCgroup() {
  thaw();
  ::close(freeze_fd_);
  // Whatever is still in it goes back where rosguard is, so that the directory can go.
  for (pid_t p : procs())
    write_file(home_, std::to_string(p), nullptr);
  for (int i = 0; i < 100 && ::rmdir(path_.c_str()) != 0 && errno == EBUSY; ++i)
    ::usleep(1000);  // a killed process leaves the cgroup when it is reaped: a moment later
}

void FreezerCgroup::add(pid_t pid) {
  int err = 0;
  if (!write_file(path_ + "/cgroup.procs", std::to_string(pid), &err))
    throw RunError("cannot move process " + std::to_string(pid) + " into " + path_ +
                   "/cgroup.procs: " + errno_text(err));
}

bool FreezerCgroup::write_freeze(const char* v, int* err) {
  if (::pwrite(freeze_fd_, v, 1, 0) == 1) return true;
  if (err) *err = errno;
  return false;
}

bool FreezerCgroup::freeze(int* err) {
  return write_freeze("1", err);
}

bool FreezerCgroup::thaw() {
  return write_freeze("0", nullptr);
}

std::vector<pid_t> FreezerCgroup::procs() const {
  std::vector<pid_t> out;
  std::ifstream in(path_ + "/cgroup.procs");
  long p;
  while (in >> p)
    out.push_back(static_cast<pid_t>(p));
  return out;
}

std::unique_ptr<Throttler> make_throttler(ThrottleKind kind, FreezerCgroup* cgroup) {
  if (kind == ThrottleKind::Freezer) {
    if (!cgroup) throw ContractError("make_throttler: the freezer needs a cgroup");
    return std::make_unique<FreezeThrottler>(*cgroup);
  }
  return std::make_unique<SpinThrottler>(kind);
}

ThrottleSched throttle_sched(ThrottleKind kind, SchedClass scenario_sched) {
  switch (kind) {
    case ThrottleKind::Fifo:
      return {scenario_sched, scenario_sched};
    case ThrottleKind::Idle:
      return {SchedClass::Other, SchedClass::Idle};
    case ThrottleKind::Freezer:
      return {SchedClass::Other, SchedClass::Other};
  }
  return {scenario_sched, scenario_sched};
}

namespace {

// What the off / on cycles of measure_hold add up to.
struct HoldTotals {
  std::uint64_t thr_count = 0, nom_count = 0;  // worker iterations held, unthrottled
  TimeNs thr_ns = 0;                           // time held (from the throttle taking the core)
  TimeNs nom_ns = 0;                           // time unthrottled
  TimeNs nom_cpu = 0;                          // the worker's CPU time unthrottled
  TimeNs delay_ns = 0;                         // command to the throttle taking the core, summed
  TimeNs resume_ns = 0;                        // release to the worker's next progress, summed
  int engaged = 0;                             // windows where the throttle took the core
  int cycles = 0;
};

// The measurement's rates and hold fraction from the totals; the fraction NaN, with the reason in
// detail, when the worker made no progress unthrottled or the throttle never took the core.
void summarize(const HoldTotals& t, HoldMeasurement& m) {
  m.nominal_us = ns_to_us(t.nom_ns);
  m.throttled_us = ns_to_us(t.thr_ns);
  m.windows = t.engaged;
  m.activation_us = t.engaged > 0 ? ns_to_us(t.delay_ns) / t.engaged : 0.0;
  m.resume_us = t.cycles > 0 ? ns_to_us(t.resume_ns) / t.cycles : 0.0;
  m.nominal_cpu_share =
      t.nom_ns > 0 ? static_cast<double>(t.nom_cpu) / static_cast<double>(t.nom_ns) : 0;
  m.nominal_per_us = t.nom_ns > 0 ? static_cast<double>(t.nom_count) / ns_to_us(t.nom_ns) : 0.0;
  const double thr_rate =
      t.thr_ns > 0 ? static_cast<double>(t.thr_count) / ns_to_us(t.thr_ns) : 0.0;
  if (m.nominal_per_us <= 0.0 || t.engaged == 0) {
    m.hold_fraction = std::numeric_limits<double>::quiet_NaN();
    m.detail += std::string(m.detail.empty() ? "" : "; ") +
                (m.nominal_per_us <= 0.0
                     ? "not measured: the worker made no progress unthrottled (the core is held "
                       "by higher-priority work)"
                     : "not measured: the throttle thread never took the core");
    return;
  }
  m.hold_fraction = thr_rate / m.nominal_per_us;
}

}  // namespace

HoldMeasurement measure_hold(ThrottleKind kind, int core, const HoldProbeOptions& opt) {
  std::optional<FreezerCgroup> cg;
  if (kind == ThrottleKind::Freezer) {
    std::string why;
    const auto root = freezer_root(&why);
    if (!root) throw RunError("freezer: " + why);
    cg.emplace(*root, "rosguard-" + std::to_string(::getpid()) + "-hold");
  }
  Worker worker(core, kind == ThrottleKind::Idle);
  if (cg) cg->add(worker.pid());
  auto throttler = make_throttler(kind, cg ? &*cg : nullptr);

  // The driver (this thread) away from the measured core where there is another one.
  int driver_core = -1;
  for (int c : usable_cpus())
    if (c != core) {
      driver_core = c;
      break;
    }
  const ThrottleSched sched = throttle_sched(kind, SchedClass::Fifo);
  const SchedOps& ops = opt.ops ? *opt.ops : system_sched_ops();
  ScopedSched driver(ThreadSpec{"", driver_core, SchedClass::Other, prio::kEngine}, ops);

  std::atomic<bool> held{false}, stop{false};
  // Set by the throttle thread when it has taken the core (the window's hold starts there; the
  // time from the command to it is the activation delay, reported apart).
  std::atomic<TimeNs> engaged_t{-1};
  std::atomic<std::uint64_t> engaged_count{0};
  Waker wake;
  RtThread thr(
      ThreadSpec{"thr-probe", core, sched.control, prio::kThr},
      [&] {
        while (true) {
          // The epoch before the flags: a stop or hold notified after this read ends the wait
          // below; read after the flags, a notify in between was lost (the probe hung in join).
          const auto e = wake.epoch();
          if (stop.load(std::memory_order_acquire)) break;
          if (held.load(std::memory_order_acquire)) {
            engaged_count.store(worker.count(), std::memory_order_relaxed);
            engaged_t.store(now_ns(), std::memory_order_release);
            throttler->hold([&] { return held.load(std::memory_order_relaxed); }, wake);
            continue;
          }
          wake.wait(e, -1);
        }
      },
      {}, ops);
  HoldMeasurement m;
  m.kind = kind;
  m.detail = thr.outcome().detail;
  const auto set_held = [&](bool v) {
    held.store(v, std::memory_order_release);
    wake.notify();
  };
  TimeNs t = now_ns() + 20 * kNsPerMs;  // the worker starts and settles
  sleep_until(t);
  HoldTotals tot;
  for (int i = 0; i < opt.cycles; ++i) {
    // The unthrottled window starts when the worker runs again: the release itself (a thaw, the
    // throttle thread's wake-up on the core) is not nominal progress.
    const TimeNs released = now_ns();
    for (const std::uint64_t c = worker.count();
         worker.count() == c && now_ns() - released < static_cast<TimeNs>(opt.off_ms * 1e6);)
      sleep_until(now_ns() + 20 * kNsPerUs);
    const TimeNs t0 = now_ns();
    tot.resume_ns += t0 - released;
    const std::uint64_t c0 = worker.count();
    const TimeNs cpu0 = worker.cpu_ns();
    sleep_until(t0 + static_cast<TimeNs>(opt.off_ms * 1e6));
    const TimeNs t1 = now_ns();
    const std::uint64_t c1 = worker.count();
    tot.nom_cpu += worker.cpu_ns() - cpu0;
    engaged_t.store(-1, std::memory_order_release);
    set_held(true);
    sleep_until(t1 + static_cast<TimeNs>(opt.on_ms * 1e6));
    const TimeNs t2 = now_ns();
    const std::uint64_t c2 = worker.count();
    const TimeNs te = engaged_t.load(std::memory_order_acquire);
    const std::uint64_t ce = engaged_count.load(std::memory_order_relaxed);
    set_held(false);
    tot.nom_count += c1 - c0;
    tot.nom_ns += t1 - t0;
    if (te >= t1 && te < t2 && ce <= c2) {
      ++tot.engaged;
      tot.thr_count += c2 - ce;
      tot.thr_ns += t2 - te;
      tot.delay_ns += te - t1;
    }
  }
  tot.cycles = opt.cycles;
  stop.store(true, std::memory_order_release);
  wake.notify();
  thr.join();
  summarize(tot, m);
  return m;
}

std::string describe_hold(const HoldMeasurement& m) {
  char buf[160];
  if (std::isnan(m.hold_fraction))
    std::snprintf(buf, sizeof buf, "%s not measured", std::string(to_string(m.kind)).c_str());
  else
    std::snprintf(buf, sizeof buf, "%s %.2f %% (activation %.0f us)",
                  std::string(to_string(m.kind)).c_str(), 100.0 * m.hold_fraction, m.activation_us);
  return buf;
}

std::optional<std::string> fifo_refused(const SchedOps& ops) {
  int rc = 0;
  std::thread t([&] {
    sched_param sp{};
    sp.sched_priority = 1;
    rc = ops.set_scheduler(::pthread_self(), SCHED_FIFO, &sp);
  });
  t.join();
  if (rc == 0) return std::nullopt;
  return errno_text(rc);
}

std::optional<std::string> throttle_unavailable(ThrottleMode mode, bool commands_only) {
  if (mode != ThrottleMode::Freezer) return std::nullopt;
  if (!commands_only)
    return "the freezer freezes processes, and a built-in workload is a thread of rosguard: use "
           "idle or fifo, or external commands";
  std::string why;
  if (!freezer_root(&why)) return "no usable cgroup v2 freezer here: " + why;
  return std::nullopt;
}

ThrottleChoice choose_throttle(const ThrottleNeeds& needs, const SchedOps& ops) {
  ThrottleChoice c;
  HoldProbeOptions opt;
  opt.ops = &ops;
  const auto fifo_err = fifo_refused(ops);
  const auto measure = [&](ThrottleKind k) {
    c.measured.push_back(measure_hold(k, needs.core, opt));
    return c.measured.back();
  };
  switch (needs.mode) {
    case ThrottleMode::Fifo:
      c.kind = ThrottleKind::Fifo;
      c.why = "hw.throttle is fifo";
      if (fifo_err && needs.scenario_sched == SchedClass::Fifo)
        c.fallback = "SCHED_FIFO refused (" + *fifo_err +
                     ") with hw.throttle fifo: THR runs under a nice value, which holds the core "
                     "only approximately";
      measure(c.kind);
      return c;
    case ThrottleMode::Idle:
      c.kind = ThrottleKind::Idle;
      c.why = "hw.throttle is idle";
      measure(c.kind);
      return c;
    case ThrottleMode::Freezer: {
      std::string why;
      c.freezer_root = freezer_root(&why);
      if (!c.freezer_root) throw RunError("hw.throttle freezer: " + why);
      c.kind = ThrottleKind::Freezer;
      c.why = "hw.throttle is freezer";
      measure(c.kind);
      return c;
    }
    case ThrottleMode::Auto:
      break;
  }
  if (needs.scenario_sched == SchedClass::Fifo && !fifo_err) {
    c.kind = ThrottleKind::Fifo;
    c.why = "auto: SCHED_FIFO is allowed (the paper's throttle)";
    measure(c.kind);
    return c;
  }
  std::vector<ThrottleKind> candidates{ThrottleKind::Idle};
  std::string no_freezer;
  if (needs.commands_only) {
    c.freezer_root = freezer_root(&no_freezer);
    if (c.freezer_root) candidates.push_back(ThrottleKind::Freezer);
  } else {
    no_freezer = "built-in workloads are threads of rosguard";
  }
  std::string figures;
  // Unmeasured (NaN) loses to any measurement; among unmeasured ones the freezer, which holds
  // by construction (a frozen task does not run at all), goes before idle.
  double best = 2.0;
  bool any = false;
  c.kind = candidates.back();
  for (ThrottleKind k : candidates) {
    const auto m = measure(k);
    figures += (figures.empty() ? "" : ", ") + describe_hold(m);
    if (!std::isnan(m.hold_fraction) && m.hold_fraction < best) {
      best = m.hold_fraction;
      c.kind = k;
      any = true;
    }
  }
  if (!any) figures += " (no measurement: the freezer where available, else idle)";
  if (c.kind != ThrottleKind::Freezer) c.freezer_root.reset();
  const std::string reason =
      fifo_err ? "SCHED_FIFO refused (" + *fifo_err + ")" : std::string("hw.scheduler is other");
  c.why = "auto: " + reason + "; measured nRT progress while throttled / nominal: " + figures +
          (no_freezer.empty() ? "" : "; freezer not available: " + no_freezer) + "; lowest wins";
  if (fifo_err)
    c.fallback = reason + ": nRT cores are throttled with '" + std::string(to_string(c.kind)) +
                 "' instead of the SCHED_FIFO idle loop (measured hold: " + figures + ")";
  return c;
}

}  // namespace rosguard::hw

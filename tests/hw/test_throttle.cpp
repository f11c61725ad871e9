// Throttling without SCHED_FIFO (hw/throttle/throttle.h): the idle and freezer mechanisms stop a
// worker pinned on the core (progress while throttled under 5 % of nominal), auto picks SCHED_FIFO
// where it is allowed and a measured fallback where it is refused, and the freezer's cgroup goes
// away with its owner.
#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cerrno>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "core/error.h"
#include "hw/common/sys.h"
#include "hw/throttle/throttle.h"
#include "hw_test_files.h"

using namespace rosguard;
using namespace rosguard::hw;
namespace fs = std::filesystem;
using rosguard::test::lines_of;
using rosguard::test::slurp;

namespace {

int probe_core() {
  const auto cpus = usable_cpus();
  return cpus.back();  // away from CPU 0, where most of the host's own work lands
}

// A measurement on a core that other processes shared says little (they slow the nominal rate
// too): take it again, up to three times, and report the last.
HoldMeasurement measure_quiet(ThrottleKind kind, const HoldProbeOptions& opt = {}) {
  HoldMeasurement m;
  for (int i = 0; i < 3; ++i) {
    m = measure_hold(kind, probe_core(), opt);
    if (m.nominal_cpu_share > 0.8 && !std::isnan(m.hold_fraction)) break;
  }
  return m;
}

SchedOps fifo_refusing_ops() {
  SchedOps ops = system_sched_ops();
  const auto real = ops.set_scheduler;
  ops.set_scheduler = [real](pthread_t t, int policy, const sched_param* p) {
    return policy == SCHED_FIFO ? EPERM : real(t, policy, p);
  };
  return ops;
}

}  // namespace

TEST_CASE("the idle throttle holds a SCHED_IDLE worker under 5 % of its nominal progress",
          "[hw][throttle]") {
  const HoldMeasurement m = measure_quiet(ThrottleKind::Idle);
  INFO("hold " << 100.0 * m.hold_fraction << " %, nominal CPU share " << m.nominal_cpu_share
               << ", resumed " << m.resume_us << " us after each release, " << m.detail);
  if (m.nominal_cpu_share <= 0.8 || std::isnan(m.hold_fraction)) {
    WARN(
        "SKIPPED: the probed core was shared with other work in three attempts (nominal CPU "
        "share of the worker "
        << m.nominal_cpu_share << ")");
    return;
  }
  CHECK(m.nominal_per_us > 0.0);
  CHECK(m.windows == HoldProbeOptions{}.cycles);
  CHECK(m.hold_fraction < 0.05);
}

TEST_CASE("without the throttle the same probe sees no hold (the measurement can fail)",
          "[hw][throttle]") {
  // Control: a spinning THR at SCHED_OTHER beside a worker at SCHED_OTHER (both nice 0) shares the
  // core about evenly, far from the idle mechanism's sliver. Run as the fifo probe with SCHED_FIFO
  // and the nice fallback both refused, so THR stays at nice 0. (With the fallback's nice -15 the
  // worker's fair share is about 3 %, which CFS hands out in slices of milliseconds: in 20 ms
  // windows it got 0.007 % in 1 of 4 runs on the idle 2-vCPU VM, 2026-11-27.)
  SchedOps ops = system_sched_ops();
  const auto real = ops.set_scheduler;
  ops.set_scheduler = [real](pthread_t t, int policy, const sched_param* p) {
    return policy == SCHED_FIFO ? EPERM : real(t, policy, p);
  };
  ops.set_nice = [](pid_t, int) { return EPERM; };
  HoldProbeOptions opt;
  opt.ops = &ops;
  const HoldMeasurement m = measure_quiet(ThrottleKind::Fifo, opt);
  INFO("hold " << 100.0 * m.hold_fraction << " %, " << m.detail);
  CHECK_THAT(m.detail, Catch::Contains("SCHED_FIFO priority 40 refused"));
  if (m.nominal_cpu_share <= 0.8 || std::isnan(m.hold_fraction)) {
    WARN("SKIPPED (the check): the probed core was shared with other work in three attempts");
    return;
  }
  // About half; a third with one more busy process on the core.
  CHECK(m.hold_fraction > 0.1);
}

TEST_CASE("the cgroup v2 freezer stops a worker process while throttled", "[hw][throttle]") {
  std::string why;
  if (!freezer_root(&why)) {
    WARN("SKIPPED: no usable cgroup v2 freezer: " << why);
    return;
  }
  const HoldMeasurement m = measure_quiet(ThrottleKind::Freezer);
  INFO("hold " << 100.0 * m.hold_fraction << " %, nominal CPU share " << m.nominal_cpu_share
               << ", resumed " << m.resume_us << " us after each release");
  if (m.nominal_cpu_share <= 0.8 || std::isnan(m.hold_fraction)) {
    WARN(
        "SKIPPED: the probed core was shared with other work in three attempts (nominal CPU "
        "share of the worker "
        << m.nominal_cpu_share << ")");
    return;
  }
  CHECK(m.hold_fraction < 0.05);
  // Nothing left behind: the probe's cgroup is gone.
  const std::string mine = "rosguard-" + std::to_string(::getpid()) + "-";
  for (const auto& e : fs::directory_iterator(*freezer_root(nullptr)))
    CHECK(e.path().filename().string().rfind(mine, 0) != 0);
}

TEST_CASE("a freezer cgroup freezes, thaws and removes itself", "[hw][throttle]") {
  std::string why;
  const auto root = freezer_root(&why);
  if (!root) {
    WARN("SKIPPED: no usable cgroup v2 freezer: " << why);
    return;
  }
  std::string path;
  {
    FreezerCgroup cg(*root, "rosguard-" + std::to_string(::getpid()) + "-unit");
    path = cg.path();
    const pid_t child = ::fork();
    REQUIRE(child >= 0);
    if (child == 0) {
      ::pause();
      ::_exit(0);
    }
    cg.add(child);
    CHECK(cg.procs() == std::vector<pid_t>{child});
    REQUIRE(cg.freeze());
    // cgroup.events says "frozen 1" once every task has stopped.
    bool frozen = false;
    for (int i = 0; i < 200 && !frozen; ++i) {
      frozen = slurp(path + "/cgroup.events").find("frozen 1") != std::string::npos;
      if (!frozen) ::usleep(1000);
    }
    CHECK(frozen);
    CHECK(cg.thaw());
    ::kill(child, SIGKILL);
    ::waitpid(child, nullptr, 0);
  }
  CHECK_FALSE(fs::exists(path));
}

TEST_CASE("auto picks SCHED_FIFO where allowed and a measured fallback where refused",
          "[hw][throttle]") {
  ThrottleNeeds needs;
  needs.core = probe_core();
  if (!fifo_refused()) {
    const ThrottleChoice c = choose_throttle(needs);
    CHECK(c.kind == ThrottleKind::Fifo);
    CHECK(c.fallback.empty());
    REQUIRE(c.measured.size() == 1);
  }
  const SchedOps refusing = fifo_refusing_ops();
  needs.commands_only = true;
  const ThrottleChoice c = choose_throttle(needs, refusing);
  INFO(c.why);
  CHECK(c.kind != ThrottleKind::Fifo);
  CHECK_THAT(c.fallback, Catch::Contains("SCHED_FIFO refused (EPERM"));
  CHECK_THAT(c.why, Catch::Contains("idle"));
  // Every available candidate was measured, and the lowest one won.
  const bool freezer = freezer_root(nullptr).has_value();
  REQUIRE(c.measured.size() == (freezer ? 2u : 1u));
  for (const auto& m : c.measured)
    if (m.kind == c.kind && !std::isnan(m.hold_fraction))
      for (const auto& o : c.measured)
        if (!std::isnan(o.hold_fraction)) CHECK(m.hold_fraction <= o.hold_fraction);
  CHECK(c.freezer_root.has_value() == (c.kind == ThrottleKind::Freezer));
  // Built-in workloads are threads: the freezer is not a candidate.
  needs.commands_only = false;
  const ThrottleChoice b = choose_throttle(needs, refusing);
  CHECK(b.kind == ThrottleKind::Idle);
  CHECK(b.measured.size() == 1);
  CHECK(throttle_unavailable(ThrottleMode::Freezer, false).has_value());
}

TEST_CASE("as an unprivileged user SCHED_FIFO is refused and the idle throttle still holds",
          "[hw][throttle][fallback]") {
  if (::geteuid() != 0 || ::access("/usr/bin/setpriv", X_OK) != 0) {
    WARN("SKIPPED: needs root and setpriv to run rosguard as the user nobody");
    return;
  }
  const fs::path dir =
      fs::temp_directory_path() / ("rosguard-throttle-nobody-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  fs::permissions(dir, fs::perms::all);
  std::string out;
  for (int attempt = 0; attempt < 3; ++attempt) {
    const pid_t pid = ::fork();
    REQUIRE(pid >= 0);
    if (pid == 0) {
      const int fd = ::open((dir / "out").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0666);
      ::dup2(fd, 1);
      ::dup2(fd, 2);
      ::setenv("ROSGUARD_HOME", ROSGUARD_TEST_SOURCE_DIR, 1);
      ::execl("/usr/bin/setpriv", "setpriv", "--reuid=65534", "--regid=65534", "--clear-groups",
              ROSGUARD_BINARY, "list", "throttles", static_cast<char*>(nullptr));
      ::_exit(127);
    }
    int status = 0;
    REQUIRE(::waitpid(pid, &status, 0) == pid);
    out = slurp(dir / "out");
    REQUIRE(WIFEXITED(status));
    REQUIRE(WEXITSTATUS(status) == 0);
    if (out.find("share unthrottled 0.9") != std::string::npos ||
        out.find("share unthrottled 1.0") != std::string::npos)
      break;  // the idle line (measured second) ran on a quiet core
  }
  INFO(out);
  CHECK_THAT(out, Catch::Contains("SCHED_FIFO refused (EPERM"));
  // No cgroup of its own for nobody: the freezer is unavailable, and says why.
  CHECK_THAT(out, Catch::Contains("freezer           unavailable here"));
  if (out.find("  idle              not measured") != std::string::npos) {
    WARN("SKIPPED (the figure): other work held the probed core (the SCHED_IDLE worker never ran)");
    fs::remove_all(dir);
    return;
  }
  const auto at = out.find("  idle              hold ");
  REQUIRE(at != std::string::npos);
  const double hold_pct = std::strtod(out.c_str() + at + 25, nullptr);
  const auto share_at = out.find("share unthrottled ", at);
  REQUIRE(share_at != std::string::npos);
  const double share = std::strtod(out.c_str() + share_at + 18, nullptr);
  if (share < 0.8) {
    WARN("SKIPPED (the figure): the probed core was shared with other work (worker share " << share
                                                                                           << ")");
  } else {
    CHECK(hold_pct < 5.0);
  }
  fs::remove_all(dir);
}

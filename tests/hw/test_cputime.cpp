// The guard's cputime source (hw/guard/core_tasks.h, CpuTimeGroup): the CPU time of another
// process's running thread, read up to date. The thread only computes (a system call of its own
// would bring the kernel's account of it up to date and hide the difference).
#include <sched.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <catch2/catch.hpp>
#include <chrono>
#include <cstdint>
#include <ctime>
#include <thread>
#include <vector>

#include "hw/guard/core_tasks.h"

using namespace rosguard;
using namespace rosguard::hw;

namespace {

// A child process that computes on the last CPU and makes no system call.
class Spinner {
 public:
  Spinner() {
    pid_ = ::fork();
    REQUIRE(pid_ >= 0);
    if (pid_ == 0) {
      cpu_set_t set;
      CPU_ZERO(&set);
      CPU_SET(static_cast<int>(std::max(1L, ::sysconf(_SC_NPROCESSORS_ONLN)) - 1), &set);
      ::sched_setaffinity(0, sizeof set, &set);
      volatile std::uint64_t n = 0;
      for (;;)
        n = n + 1;
    }
  }
  ~Spinner() {
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
  }
  Spinner(const Spinner&) = delete;
  Spinner& operator=(const Spinner&) = delete;
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
};

}  // namespace

// /proc/<tid>/schedstat, the source before, moves for a running thread only at scheduler ticks
// (and at its system calls): read every millisecond, a computing thread's time came in 4 ms
// steps at 250 Hz, so three readings in four showed no progress. A perf task_clock event read
// brings the count up to date: every reading made while the thread runs shows progress. So the
// share of readings that show progress must be near the share of the time the thread ran (it
// may share its CPU with other work on a busy machine).
TEST_CASE("guard cputime source: a running thread's CPU time is read up to date, not per tick",
          "[guard][cputime]") {
  Spinner spinner;
  std::this_thread::sleep_for(std::chrono::milliseconds(20));  // it runs on its CPU
  CpuTimeGroup group;
  group.publish({spinner.pid()});
  CounterValue v;
  group.read({&v, 1});
  if (const std::string why = group.fallback(); !why.empty()) {
    WARN("perf task_clock refused here, the source reads /proc/<tid>/schedstat: " << why);
    return;
  }
  const std::uint64_t first = v.value;
  const auto start = std::chrono::steady_clock::now();
  constexpr int kReads = 200;
  int progressed = 0;
  std::uint64_t last = first;
  for (int i = 0; i < kReads; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
    group.read({&v, 1});
    progressed += v.value > last ? 1 : 0;
    last = v.value;
  }
  const double wall_ns =
      std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - start).count();
  const double ran = static_cast<double>(last - first) / wall_ns;  // its share of the time
  const double shown = static_cast<double>(progressed) / kReads;
  INFO("the thread ran " << 100.0 * ran << " % of " << wall_ns / 1e6 << " ms; " << 100.0 * shown
                         << " % of " << kReads << " readings showed progress");
  if (ran < 0.5) {
    WARN("the thread ran under half the time (a busy CPU): nothing to judge");
    return;
  }
  CHECK(shown >= 0.8 * ran);
}

// Executors: SCHED_FIFO priorities and affinity as requested, the fallback when the system
// refuses (injected EPERM / EINVAL), RAII restore, and no thread left under SCHED_FIFO.
#include <sched.h>
#include <unistd.h>

#include <catch2/catch.hpp>

#include "hw/common/sys.h"
#include "hw/executor/executor.h"

using namespace rosguard::hw;

namespace {

bool fifo_allowed() {
  sched_param p{};
  p.sched_priority = 1;
  if (::pthread_setschedparam(::pthread_self(), SCHED_FIFO, &p) != 0) return false;
  p.sched_priority = 0;
  ::pthread_setschedparam(::pthread_self(), SCHED_OTHER, &p);
  return true;
}

ThreadSchedInfo info_of(pid_t tid) {
  for (const auto& t : process_threads())
    if (t.tid == tid) return t;
  return {};
}

}  // namespace

TEST_CASE("an RtThread runs pinned under SCHED_FIFO at its priority", "[hw][executor]") {
  if (!fifo_allowed()) {
    WARN("SKIPPED: SCHED_FIFO not permitted for this user");
    return;
  }
  std::atomic<bool> checked{false};
  ThreadSchedInfo seen;
  int cpu = -1;
  std::atomic<bool> release{false};
  {
    const int core = usable_cpus().back();
    RtThread t(ThreadSpec{"fifo-test", core, SchedClass::Fifo, prio::kThr}, [&] {
      cpu = ::sched_getcpu();
      while (!release.load())
        ::usleep(1000);
    });
    CHECK(t.outcome().fifo);
    CHECK(t.outcome().pinned);
    CHECK(t.outcome().detail.empty());
    seen = info_of(t.tid());
    release = true;
  }
  CHECK(seen.policy == SCHED_FIFO);
  CHECK(seen.rt_priority == prio::kThr);
  CHECK(seen.name == "fifo-test");
  CHECK(cpu == usable_cpus().back());
  CHECK(realtime_threads().empty());  // joined: nothing left under SCHED_FIFO
  (void)checked;
}

TEST_CASE("priorities on an nRT core follow CFB > THR > PMC > NCT", "[hw][executor]") {
  CHECK(prio::kCfb > prio::kThr);
  CHECK(prio::kThr > prio::kPmc);
  CHECK(prio::kPmc > prio::kNct);
  CHECK(prio::kController > prio::kCfb);
  CHECK(prio::kThr > prio::kRt);
  CHECK(prio::nice_for(prio::kCfb) < prio::nice_for(prio::kThr));
  CHECK(prio::nice_for(prio::kThr) < prio::nice_for(prio::kPmc));
  CHECK(prio::nice_for(prio::kPmc) < prio::nice_for(prio::kNct));
}

TEST_CASE("when SCHED_FIFO is refused the thread falls back, and says so", "[hw][executor]") {
  SchedOps ops = system_sched_ops();
  ops.set_scheduler = [](pthread_t, int, const sched_param*) { return EPERM; };
  ThreadSchedInfo seen;
  {
    RtThread t(
        ThreadSpec{"no-fifo", 0, SchedClass::Fifo, prio::kCfb}, [] {}, {}, ops);
    CHECK_FALSE(t.outcome().fifo);
    CHECK(t.outcome().pinned);
    CHECK_THAT(t.outcome().detail, Catch::Contains("EPERM") && Catch::Contains("SCHED_OTHER") &&
                                       Catch::Contains("no-fifo"));
  }
  CHECK(realtime_threads().empty());
}

TEST_CASE("a core that cannot be used is a fallback, not an error", "[hw][executor]") {
  SchedOps ops = system_sched_ops();
  ops.set_affinity = [](pthread_t, std::size_t, const cpu_set_t*) { return EINVAL; };
  RtThread t(
      ThreadSpec{"no-core", 7, SchedClass::Other, prio::kNct}, [] {}, {}, ops);
  CHECK_FALSE(t.outcome().pinned);
  CHECK_THAT(t.outcome().detail, Catch::Contains("core 7") && Catch::Contains("EINVAL"));
}

TEST_CASE("ScopedSched restores the calling thread's policy and affinity", "[hw][executor]") {
  if (!fifo_allowed()) {
    WARN("SKIPPED: SCHED_FIFO not permitted for this user");
    return;
  }
  cpu_set_t before;
  ::sched_getaffinity(0, sizeof before, &before);
  {
    ScopedSched s(ThreadSpec{"scoped", 0, SchedClass::Fifo, prio::kPmc});
    CHECK(::sched_getscheduler(0) == SCHED_FIFO);
    CHECK(::sched_getcpu() == 0);
  }
  CHECK(::sched_getscheduler(0) == SCHED_OTHER);
  cpu_set_t after;
  ::sched_getaffinity(0, sizeof after, &after);
  CHECK(CPU_EQUAL(&before, &after));
}

TEST_CASE("an exception in a thread body is kept and reported", "[hw][executor]") {
  std::string who;
  RtThread t(
      ThreadSpec{"thrower", -1, SchedClass::Other, prio::kNct},
      [] { throw std::runtime_error("boom"); },
      [&](const std::string& name, std::exception_ptr) { who = name; });
  t.join();
  CHECK(t.error());
  CHECK(who == "thrower");
}

// rosguard's own threads off the measured cores, and the measured CPUs timed before a run
// (hw/housekeeping.h, hw/cpu_speed.h; docs/design.md section 5): the choice of CPUs, the pin and
// what it publishes, the slow-CPU rule. No timing assertion.
#include <sched.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <set>

#include "hw/common/sys.h"
#include "hw/cpu_speed.h"
#include "hw/housekeeping.h"

using namespace rosguard::hw;

TEST_CASE("housekeeping CPUs: a spare CPU, else the controller's, else shared",
          "[hw][housekeeping]") {
  // 16 CPUs, RT on 0, nRT on 1-7, controller on 8: the spare ones.
  std::vector<int> usable;
  for (int c = 0; c < 16; ++c)
    usable.push_back(c);
  auto p = plan_housekeeping(usable, {0, 1, 2, 3, 4, 5, 6, 7}, {8});
  CHECK(p.kind == HousekeepingPlan::Kind::Spare);
  CHECK(p.cpus == std::vector<int>{9, 10, 11, 12, 13, 14, 15});
  CHECK(p.detail.rfind("CPU 9-15: no node of the run uses them", 0) == 0);

  // Every CPU a node's; the controller alone on 15.
  std::set<int> measured;
  for (int c = 0; c < 15; ++c)
    measured.insert(c);
  p = plan_housekeeping(usable, measured, {15});
  CHECK(p.kind == HousekeepingPlan::Kind::Controller);
  CHECK(p.cpus == std::vector<int>{15});

  // 2 CPUs, the controller shares CPU 0 with the RT node (scenarios/bench/hw-activation.json).
  p = plan_housekeeping({0, 1}, {0, 1}, {0});
  CHECK(p.kind == HousekeepingPlan::Kind::SharedController);
  CHECK(p.cpus == std::vector<int>{0});

  // A controller core outside the usable CPUs, nothing spare: unpinned.
  p = plan_housekeeping({0, 1}, {0, 1}, {5});
  CHECK(p.kind == HousekeepingPlan::Kind::None);
  CHECK(p.cpus.empty());

  CHECK(cpu_ranges({0, 1, 2, 4, 6, 7}) == "0-2, 4, 6-7");
  CHECK(cpu_ranges({}) == "none");
}

TEST_CASE("the housekeeping pin: the calling thread, threads it starts, and back",
          "[hw][housekeeping]") {
  const std::vector<int> usable = usable_cpus();
  const auto mask = [] {
    cpu_set_t set;
    CPU_ZERO(&set);
    ::sched_getaffinity(0, sizeof set, &set);
    std::vector<int> out;
    for (int c = 0; c < CPU_SETSIZE; ++c)
      if (CPU_ISSET(c, &set)) out.push_back(c);
    return out;
  };
  const std::vector<int> before = mask();
  CHECK(housekeeping_cpus().empty());
  {
    HousekeepingPin pin({usable.back()});
    REQUIRE(pin.error().empty());
    CHECK(mask() == std::vector<int>{usable.back()});
    CHECK(housekeeping_cpus() == std::vector<int>{usable.back()});
    // usable_cpus() still says what the process may use, not where its own threads sit.
    CHECK(usable_cpus() == usable);
    // A thread started now inherits the mask (as Cyclone DDS's threads do).
    std::vector<int> inherited;
    std::thread([&] { inherited = mask(); }).join();
    CHECK(inherited == std::vector<int>{usable.back()});
    bool seen = false;
    for (const auto& t : thread_placements())
      seen = seen || (t.tid == current_tid() && t.cpus == std::vector<int>{usable.back()});
    CHECK(seen);
  }
  CHECK(mask() == before);
  CHECK(housekeeping_cpus().empty());
}

TEST_CASE("slow CPUs: below the fastest by more than the margin", "[hw][cpu_speed]") {
  const auto cpu = [](int c, double mbps) { return CpuSpeed{c, true, {mbps}, mbps, 0.0}; };
  // The 16-vCPU VM of issue 22: 25, 35, 60 and 72 GB/s at 2 MB.
  const std::vector<CpuSpeed> cpus = {cpu(15, 25000), cpu(0, 35000), cpu(1, 60000), cpu(7, 72000),
                                      cpu(3, 66000)};
  const auto slow = slow_cpus(cpus, kSlowCpuMargin);
  REQUIRE(slow.size() == 3);
  CHECK(slow[0].cpu == 15);  // slowest first
  CHECK(slow[1].cpu == 0);
  CHECK(slow[2].cpu == 1);  // 60 < 0.9 x 72
  CHECK(slow_cpus({cpu(0, 100), cpu(1, 91)}, 0.10).empty());
  CHECK(slow_cpus({cpu(0, 100), cpu(1, std::nan(""))}, 0.10).empty());
  CHECK(slow_cpus({}, 0.10).empty());
}

TEST_CASE("the CPU speed probe times every CPU asked, in windows", "[hw][cpu_speed]") {
  const std::vector<int> cpus = usable_cpus();
  CpuSpeedOptions o;
  o.windows = 3;
  o.window_ms = 2.0;
  const CpuSpeedReport r = time_cpus(cpus, SchedClass::Other, o);
  REQUIRE(r.cpus.size() == cpus.size());
  CHECK(r.passes >= 1);
  for (std::size_t i = 0; i < cpus.size(); ++i) {
    CHECK(r.cpus[i].cpu == cpus[i]);
    CHECK(r.cpus[i].windows_mbps.size() == 3);
    CHECK(r.cpus[i].mbps > 0.0);
  }
  CHECK(time_cpus({}, SchedClass::Other, o).cpus.empty());
}

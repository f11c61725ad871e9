// PMC sources: the named-event table per architecture, the perf path with software events (per
// thread, per process, per CPU), the hardware path where a PMU exists, the instrumented source,
// and the external command's process group.
#include <linux/perf_event.h>
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include "core/error.h"
#include "hw/common/clock.h"
#include "hw/pmc_source/perf.h"
#include "hw/pmc_source/perf_events.h"
#include "hw/pmc_source/pmc_source.h"
#include "hw/workload/work_counters.h"
#include "hw/workload/workload.h"

using namespace rosguard;
using namespace rosguard::hw;

namespace {

void busy_for(TimeNs ns) {
  const TimeNs end = now_ns() + ns;
  volatile std::uint64_t x = 0;
  while (now_ns() < end)
    x = x + 1;
}

std::vector<CounterValue> read_all(CounterGroup& g) {
  std::vector<CounterValue> v(g.size());
  g.read(v);
  return v;
}

}  // namespace

TEST_CASE("aarch64 event table gives the ARMv8 PMUv3 raw codes", "[hw][events]") {
  const std::pair<const char*, std::uint64_t> expected[] = {
      {"cpu_cycles", 0x11},   {"inst_retired", 0x08}, {"l2d_cache_refill", 0x17},
      {"l2d_cache_wb", 0x18}, {"l3d_cache", 0x2B},    {"l3d_cache_refill", 0x2A}};
  for (const auto& [name, code] : expected) {
    INFO(name);
    const auto e = hardware_event(name, Arch::Aarch64);
    REQUIRE(e);
    CHECK(e->type == PERF_TYPE_RAW);
    CHECK(e->config == code);
  }
  CHECK_FALSE(hardware_event("l1d_cache_refill", Arch::Aarch64));
  CHECK(hardware_event_names().size() == 6);
}

TEST_CASE("x86-64 event table maps every name to the nearest generic event", "[hw][events]") {
  for (const auto& name : hardware_event_names()) {
    INFO(name);
    const auto e = hardware_event(name, Arch::X86_64);
    REQUIRE(e);
    CHECK((e->type == PERF_TYPE_HARDWARE || e->type == PERF_TYPE_HW_CACHE));
    CHECK_FALSE(e->note.empty());
  }
  CHECK(hardware_event("cpu_cycles", Arch::X86_64)->config == PERF_COUNT_HW_CPU_CYCLES);
  CHECK(hardware_event("inst_retired", Arch::X86_64)->config == PERF_COUNT_HW_INSTRUCTIONS);
  CHECK(hardware_event("l2d_cache_refill", Arch::X86_64)->config == PERF_COUNT_HW_CACHE_REFERENCES);
  CHECK(hardware_event("l3d_cache_refill", Arch::X86_64)->config == PERF_COUNT_HW_CACHE_MISSES);
  // Other architectures: only what is generic.
  CHECK(hardware_event("cpu_cycles", Arch::Other));
  CHECK_FALSE(hardware_event("l2d_cache_wb", Arch::Other));
}

TEST_CASE("software event table", "[hw][events]") {
  CHECK(software_event("task_clock")->config == PERF_COUNT_SW_TASK_CLOCK);
  CHECK(software_event("context_switches")->config == PERF_COUNT_SW_CONTEXT_SWITCHES);
  CHECK(software_event("task_clock")->type == PERF_TYPE_SOFTWARE);
  CHECK_FALSE(software_event("cpu_cycles"));
  CHECK(software_group_events().size() == 4);
}

TEST_CASE("armv8 PMU events: what sysfs says the PMUs implement, common to all of them",
          "[hw][events]") {
  namespace fs = std::filesystem;
  const fs::path devices =
      fs::temp_directory_path() / ("rosguard-pmu-" + std::to_string(::getpid()));
  fs::remove_all(devices);
  const auto event = [&](const std::string& pmu, const std::string& name, const std::string& text) {
    fs::create_directories(devices / pmu / "events");
    std::ofstream(devices / pmu / "events" / name) << text << "\n";
  };
  fs::create_directories(devices / "software");  // not an armv8_* PMU: no answer
  CHECK_FALSE(armv8_pmu_events(devices.string()));
  CHECK_FALSE(armv8_pmu_events((devices / "absent").string()));

  // What qemu-system-aarch64 -cpu max advertised (docs/orin.md): cycles and stalls only.
  event("armv8_pmuv3", "cpu_cycles", "event=0x0011");
  event("armv8_pmuv3", "stall_frontend", "event=0x0023");
  event("armv8_pmuv3", "odd", "config1=0x1");  // no event= term: skipped
  auto found = armv8_pmu_events(devices.string());
  REQUIRE(found);
  CHECK(found->codes == std::set<std::uint64_t>{0x11, 0x23});
  CHECK(found->where == (devices / "armv8_pmuv3" / "events").string());
  // What the probe and the perf source then make of the six: cpu_cycles counts, the others
  // would count 0 and are not events of this host.
  CHECK_FALSE(pmu_lacks(*hardware_event("cpu_cycles", Arch::Aarch64), found));
  const auto why = pmu_lacks(*hardware_event("l2d_cache_refill", Arch::Aarch64), found);
  REQUIRE(why);
  CHECK_THAT(*why, Catch::Contains("0x17") && Catch::Contains("L2D_CACHE_REFILL") &&
                       Catch::Contains(found->where) && Catch::Contains("count 0"));
  CHECK_FALSE(pmu_lacks(*hardware_event("l2d_cache_refill", Arch::Aarch64), std::nullopt));
  CHECK_FALSE(pmu_lacks(*hardware_event("cpu_cycles", Arch::X86_64), found));  // not raw
  CHECK_FALSE(pmu_lacks(PerfEventCode{PERF_TYPE_RAW, 0x4004, "beyond the common events"}, found));

  // Two PMUs (heterogeneous cores): the events both implement.
  event("armv8_pmuv3", "l2d_cache_refill", "event=0x0017");
  event("armv8_cortex_a55", "cpu_cycles", "event=0x0011");
  event("armv8_cortex_a55", "l2d_cache_wb", "event=0x0018");
  found = armv8_pmu_events(devices.string());
  REQUIRE(found);
  CHECK(found->codes == std::set<std::uint64_t>{0x11});
  CHECK_THAT(found->where, Catch::Contains("armv8_cortex_a55") && Catch::Contains("armv8_pmuv3"));
  fs::remove_all(devices);
}

TEST_CASE("registry lists the three sources", "[hw][pmc]") {
  PmcSourceRegistry r;
  register_builtin(r);
  REQUIRE(r.all().size() == 3);
  CHECK(r.find("perf"));
  CHECK(r.find("software"));
  CHECK(r.find("instrumented"));
  CHECK_THROWS(r.add({"perf", "", make_perf_source}));
}

TEST_CASE("software source reads a 4-event group of this thread", "[hw][pmc][software]") {
  auto src = make_software_source();
  REQUIRE_FALSE(src->unavailable_reason());
  auto g = src->open(software_group_events(), PmcTarget{});
  REQUIRE(g->size() == 4);
  const auto a = read_all(*g);
  busy_for(20 * kNsPerMs);
  const auto b = read_all(*g);
  const double ran_ms = static_cast<double>(b[0].value - a[0].value) / 1e6;
  CHECK(ran_ms > 10.0);  // task_clock counted the busy loop (some of it may be preempted)
  CHECK(ran_ms < 200.0);
  for (const auto& v : b) {
    CHECK(v.time_enabled_ns >= v.time_running_ns);
    CHECK(v.time_enabled_ns > 0);
  }
  CHECK(b[1].value >= a[1].value);  // context switches never go back
}

TEST_CASE("software source counts another thread and a CPU", "[hw][pmc][software]") {
  auto src = make_software_source();
  std::atomic<bool> stop{false};
  std::atomic<pid_t> tid{0};
  std::thread worker([&] {
    tid = ::gettid();
    volatile std::uint64_t x = 0;
    while (!stop.load())
      x = x + 1;
  });
  while (tid == 0)
    std::this_thread::yield();
  PmcTarget t;
  t.kind = PmcTarget::Kind::Thread;
  t.pid = tid;
  auto g = src->open({"task_clock", "context_switches"}, t);
  const auto a = read_all(*g);
  std::this_thread::sleep_for(std::chrono::milliseconds(30));
  const auto b = read_all(*g);
  stop = true;
  worker.join();
  CHECK(b[0].value > a[0].value);

  PmcTarget cpu;
  cpu.kind = PmcTarget::Kind::Cpu;
  cpu.cpu = 0;
  auto gc = src->open({"cpu_clock"}, cpu);
  const auto c0 = read_all(*gc);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const auto c1 = read_all(*gc);
  CHECK(c1[0].value > c0[0].value);  // cpu_clock of a CPU runs whatever it executes
}

TEST_CASE("software source counts a process and its children from exec", "[hw][pmc][software]") {
  auto src = make_software_source();
  CommandProcess proc({"sh", "-c", "i=0; while [ $i -lt 20000 ]; do i=$((i+1)); done"},
                      ThreadSpec{"t", -1, SchedClass::Other, prio::kNct});
  PmcTarget t;
  t.kind = PmcTarget::Kind::Process;
  t.pid = proc.pid();
  t.enable_on_exec = true;
  auto g = src->open(software_group_events(), t);
  CHECK(read_all(*g)[0].value == 0);  // not counting before exec
  proc.start();
  REQUIRE(proc.wait(-1));
  CHECK(WIFEXITED(proc.status()));
  const auto v = read_all(*g);
  CHECK(v[0].value > 1'000'000);  // the shell ran for more than a millisecond
}

TEST_CASE("what a command forks does not outlive it", "[hw][command]") {
  char path[] = "/tmp/rosguard-worker-XXXXXX";
  const int fd = ::mkstemp(path);
  REQUIRE(fd >= 0);
  ::close(fd);
  CommandProcess proc({"sh", "-c", std::string("sleep 30 & echo $! > ") + path},
                      ThreadSpec{"t", -1, SchedClass::Other, prio::kNct});
  proc.start();
  REQUIRE(proc.wait(-1));  // the shell exited, its background worker did not on its own
  pid_t worker = 0;
  std::ifstream(path) >> worker;
  ::unlink(path);
  REQUIRE(worker > 0);
  // Killed with the group when wait() returned: gone, or a zombie until init reaps it.
  bool dead = false;
  for (int i = 0; i < 200 && !dead; ++i) {
    std::string stat;
    std::getline(std::ifstream("/proc/" + std::to_string(worker) + "/stat"), stat);
    dead = stat.empty() || stat.find(") Z ") != std::string::npos;
    if (!dead) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  CHECK(dead);
}

TEST_CASE("an event that cannot be opened is a RunError naming it and the errno", "[hw][pmc]") {
  auto src = make_software_source();
  CHECK_THROWS_WITH(src->open({"l2d_cache_refill"}, PmcTarget{}),
                    Catch::Contains("l2d_cache_refill"));
  PmcTarget bad;
  bad.kind = PmcTarget::Kind::Thread;
  bad.pid = 0x3fffffff;  // no such thread
  CHECK_THROWS_WITH(src->open({"task_clock"}, bad),
                    Catch::Contains("task_clock") && Catch::Contains("ESRCH"));
}

TEST_CASE("perf hardware source, where the host has a PMU", "[hw][pmc][perf]") {
  auto src = make_perf_source();
  if (const auto why = src->unavailable_reason()) {
    WARN("SKIPPED: no hardware PMU on this host: " << *why);
    // The reason names the event and the errno.
    CHECK_THAT(*why, Catch::Contains("cpu_cycles"));
    CHECK(src->events().empty());
    return;
  }
  // Every event the source offers here counts a busy loop (cycles always; a PMU that does not
  // implement instructions, as qemu's without -icount, offers cpu_cycles alone: docs/orin.md).
  REQUIRE(src->provides("cpu_cycles"));
  std::vector<std::string> events = {"cpu_cycles"};
  if (src->provides("inst_retired")) events.push_back("inst_retired");
  auto g = src->open(events, PmcTarget{});
  const auto a = read_all(*g);
  busy_for(10 * kNsPerMs);
  const auto b = read_all(*g);
  for (std::size_t i = 0; i < events.size(); ++i) {
    INFO(events[i]);
    CHECK(b[i].value > a[i].value);
  }
}

TEST_CASE("instrumented source turns published cache lines into metric events",
          "[hw][pmc][instrumented]") {
  auto src = make_instrumented_source();
  CHECK_FALSE(src->unavailable_reason());
  CHECK_FALSE(src->counts_processes());
  CHECK_THROWS_WITH(src->open({"l2d_cache_refill"}, PmcTarget{}),
                    Catch::Contains("not a built-in workload"));
  WorkCounters work;
  PmcTarget t;
  t.work = &work;
  CHECK_THROWS_WITH(src->open({"cpu_cycles"}, t), Catch::Contains("cpu_cycles"));
  auto g = src->open({"l2d_cache_refill", "l2d_cache_wb"}, t);

  WorkloadInfo read{
      "r",
      "inline",
      {{"name", "r"},
       {"hw", {{"kernel", "bandwidth_read"}, {"working_set_kb", 256}, {"passes", 3}}}}};
  WorkloadInfo write{
      "w",
      "inline",
      {{"name", "w"},
       {"hw", {{"kernel", "bandwidth_write"}, {"working_set_kb", 128}, {"passes", 2}}}}};
  std::atomic<bool> stop{false};
  CHECK(make_builtin_workload(read)->run(stop, work) == Approx(1.0));
  auto v = read_all(*g);
  CHECK(v[0].value == 256 * 1024 / 64 * 3);
  CHECK(v[1].value == 0);
  CHECK(make_builtin_workload(write)->run(stop, work) == Approx(1.0));
  v = read_all(*g);
  CHECK(v[0].value == 256 * 1024 / 64 * 3 + 128 * 1024 / 64 * 2);  // writes allocate
  CHECK(v[1].value == 128 * 1024 / 64 * 2);                        // and are written back
  CHECK(v[0].time_enabled_ns == v[0].time_running_ns);
  CHECK(work.units_done.load() == 256 * 1024 / 64 * 3 + 128 * 1024 / 64 * 2);
}

TEST_CASE("a stopped built-in run reports its fraction", "[hw][workload]") {
  WorkloadInfo read{
      "r",
      "inline",
      {{"name", "r"},
       {"hw", {{"kernel", "bandwidth_read"}, {"working_set_kb", 64}, {"passes", 10}}}}};
  WorkCounters work;
  std::atomic<bool> stop{true};
  const double f = make_builtin_workload(read)->run(stop, work);
  CHECK(f > 0.0);
  CHECK(f < 0.01);
}

TEST_CASE("proxy reaches its target bandwidth roughly, on an idle core", "[hw][workload]") {
  const auto cal = calibrate_proxy(1000.0, 1024);
  INFO("ns/line " << cal.ns_per_line << ", ns/alu " << cal.ns_per_alu << ", alu/line "
                  << cal.alu_per_line << ", achievable " << cal.achievable_mbps << " MB/s");
  CHECK(cal.alu_per_line > 0);
  CHECK(cal.achievable_mbps > 1000.0);
  WorkloadInfo proxy{"p",
                     "inline",
                     {{"name", "p"},
                      {"hw",
                       {{"kernel", "proxy"},
                        {"target_mbps", 1000.0},
                        {"working_set_kb", 1024},
                        {"runtime_ms", 50.0}}}}};
  auto w = make_builtin_workload(proxy);
  WorkCounters work;
  std::atomic<bool> stop{false};
  const TimeNs t0 = now_ns();
  w->run(stop, work);
  const double s = static_cast<double>(now_ns() - t0) / 1e9;
  const double mbps = static_cast<double>(work.lines_read.load()) * 64 / kBytesPerMb / s;
  INFO("proxy ran " << s * 1e3 << " ms at " << mbps << " MB/s");
  CHECK(mbps > 300.0);  // a shared VM: only the order of magnitude is checked
  CHECK(mbps < 3000.0);
}

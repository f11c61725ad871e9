// The calibration suite: the latency kernel's chase (one cycle through every line), and a tiny
// suite run that returns well-formed Measurements which survive the JSON round trip. No timing
// targets: only positive, finite values.
#include <algorithm>
#include <atomic>
#include <catch2/catch.hpp>
#include <cmath>
#include <set>
#include <string>
#include <vector>

#include "hw/calibration/suite.h"
#include "hw/common/sys.h"
#include "hw/workload/workload.h"
#include "hw_test_files.h"

using namespace rosguard;
using namespace rosguard::hw;

namespace {

WorkloadInfo latency_info(std::size_t kb, std::uint64_t passes) {
  WorkloadInfo w;
  w.name = "latency";
  w.origin = "test";
  w.doc = {{"hw", {{"kernel", "latency"}, {"working_set_kb", kb}, {"passes", passes}}}};
  return w;
}

// Two usable cores if there are, so the co-run and far-end paths run.
std::vector<int> test_cores() {
  auto cpus = usable_cpus();
  if (cpus.size() > 2) cpus.resize(2);
  return cpus;
}

SuiteShape tiny_shape() {
  SuiteShape s;
  s.isolation_kb = {16};
  s.in_l3_kb = 64;
  s.dram_kb = 256;
  s.workload_kb = 32;
  s.corunner_counts = {1};
  s.repetitions = 2;
  s.window_ms = 2.0;
  s.warmup_ms = 2.0;
  s.cost_samples = 20;
  s.cost_spacing_us = 200.0;
  return s;
}

}  // namespace

TEST_CASE("the latency kernel's chase is one cycle through every line", "[hw][calibration]") {
  for (std::size_t lines : {2u, 3u, 64u, 1000u, 32768u}) {
    const auto next = chase_cycle(lines, 7);
    REQUIRE(next.size() == lines);
    std::vector<int> visits(lines, 0);
    std::size_t at = 0;
    for (std::size_t hop = 0; hop < lines; ++hop) {
      REQUIRE(next[at] < lines);
      at = next[at];
      ++visits[at];
    }
    INFO("lines " << lines);
    CHECK(at == 0);  // back where it started after exactly `lines` hops
    CHECK(std::all_of(visits.begin(), visits.end(), [](int v) { return v == 1; }));
  }
  CHECK(chase_cycle(1000, 1) == chase_cycle(1000, 1));
  CHECK(chase_cycle(1000, 1) != chase_cycle(1000, 2));
}

TEST_CASE("the latency kernel loads one line per hop and counts each", "[hw][calibration]") {
  auto w = make_builtin_workload(latency_info(64, 3));
  CHECK(w->kernel() == "latency");
  REQUIRE(w->units_per_run() == 64 * 1024 / 64 * 3);
  WorkCounters c;
  std::atomic<bool> stop{false};
  CHECK(w->run(stop, c) == 1.0);
  CHECK(c.lines_read.load() == w->units_per_run());
  CHECK(c.units_done.load() == w->units_per_run());
  CHECK(c.lines_written.load() == 0);
  stop = true;  // stops within one chunk
  CHECK(w->run(stop, c) < 1.0);
}

TEST_CASE("the shipped latency workload builds", "[hw][calibration]") {
  WorkloadInfo w;
  w.name = "latency";
  w.origin = "scenarios/workloads/latency.json";
  w.doc = nlohmann::json::parse(
      test::slurp(std::string(ROSGUARD_TEST_SOURCE_DIR) + "/scenarios/workloads/latency.json"));
  auto k = make_builtin_workload(w);
  CHECK(k->kernel() == "latency");
  CHECK(k->units_per_run() == 65536u * 1024u / 64u);
}

TEST_CASE("a tiny calibration suite returns well-formed measurements", "[hw][calibration]") {
  const SuiteShape shape = tiny_shape();
  SuiteOptions opt;
  opt.host.hostname = "test";
  opt.host.cpus = 2;
  opt.cores = test_cores();
  opt.shape = &shape;
  int last_step = 0, steps = 0;
  bool monotonic = true;
  opt.progress = [&](int step, int n, const std::string& what) {
    monotonic = monotonic && step == last_step + 1 && !what.empty();
    last_step = step;
    steps = n;
  };
  const SuiteResult r = run_suite(opt);
  const auto& m = r.measurements;
  CHECK_FALSE(r.stopped);
  CHECK(monotonic);
  CHECK(last_step == steps);
  CHECK(m.wall_s > 0.0);
  CHECK_FALSE(m.host.date.empty());
  CHECK(r.notes.size() >= 2);  // cores, working sets

  std::set<std::pair<std::string, double>> alone;
  int coruns = 0;
  for (const auto& k : m.runs) {
    INFO(k.kernel << " " << k.working_set_kb << " KB, " << k.corunners.size() << " co-runners");
    CHECK(std::isfinite(k.ns_per_line));
    CHECK(k.ns_per_line > 0.0);
    CHECK(std::isfinite(k.cv));
    CHECK(k.cv >= 0.0);
    CHECK(k.samples >= 1);
    CHECK(k.samples <= shape.repetitions);
    if (k.corunners.empty()) alone.insert({k.kernel, k.working_set_kb});
    for (const auto& c : k.corunners) {
      CHECK((c.kernel == "bandwidth_read" || c.kernel == "bandwidth_write"));
      CHECK((c.working_set_kb == shape.dram_kb || c.working_set_kb == shape.workload_kb));
    }
    coruns += k.corunners.empty() ? 0 : 1;
  }
  // Isolation of every kernel at every working set the suite uses.
  for (const char* kernel : {"bandwidth_read", "bandwidth_write", "latency"})
    for (double kb : {16.0, 32.0, 64.0, 256.0})
      CHECK(alone.count({kernel, kb}) == 1);
  if (opt.cores.size() > 1) {
    // Per co-runner kind: latency, read, write at in-L3 and DRAM, plus read / write at 32 KB.
    CHECK(coruns == 4 * 8);
  } else {
    CHECK(coruns == 0);
  }

  for (const char* cost : {"pmc_callback", "publish", "message_latency", "throttle_activation",
                           "external_read", "controller_callback"}) {
    INFO(cost);
    REQUIRE(m.costs_us.count(cost) == 1);
    const auto& v = m.costs_us.at(cost);
    CHECK(v.size() >= static_cast<std::size_t>(shape.cost_samples) / 2);
    CHECK(std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x) && x >= 0.0; }));
    CHECK(*std::max_element(v.begin(), v.end()) > 0.0);
  }

  nlohmann::json j = m;
  const auto back = calibration::measurements_from_json(j, "test");
  CHECK(nlohmann::json(back) == j);
  CHECK(back.runs.size() == m.runs.size());
  CHECK(back.costs_us.size() == m.costs_us.size());
}

TEST_CASE("a calibration suite asked to stop returns at once, marked partial",
          "[hw][calibration]") {
  const SuiteShape shape = tiny_shape();
  std::atomic<bool> stop{true};
  SuiteOptions opt;
  opt.cores = test_cores();
  opt.shape = &shape;
  opt.stop = &stop;
  const SuiteResult r = run_suite(opt);
  CHECK(r.stopped);
  CHECK(r.measurements.runs.empty());
  CHECK(r.measurements.costs_us.empty());
}

TEST_CASE("the suite's shape follows the host's caches and cores", "[hw][calibration]") {
  calibration::HostFacts h;
  h.l2_kb = 1024;
  h.l3_kb_per_cluster = 32768;
  const SuiteShape quick = shape_for(h, true, 16);
  // 4x the L3, or less (not under 2x) where memory is short.
  CHECK(quick.dram_kb <= 4 * 32768);
  CHECK(quick.dram_kb >= 2 * 32768);
  CHECK(quick.in_l3_kb == 4096);  // 4x the L2, within half the L3
  CHECK(quick.isolation_kb == std::vector<double>{512});
  CHECK(quick.corunner_counts == std::vector<int>{1, 2, 4, 8, 15});
  const SuiteShape full = shape_for(h, false, 16);
  CHECK(full.corunner_counts.empty());  // every count
  REQUIRE_FALSE(full.isolation_kb.empty());
  CHECK(full.isolation_kb.front() == 16);
  CHECK(full.isolation_kb.back() * 2 == full.dram_kb);
  CHECK(full.repetitions > quick.repetitions);
  CHECK(shape_for(h, true, 2).corunner_counts == std::vector<int>{1});
}

// The calibration suite: the latency kernel's chase (one cycle through every line), a tiny suite
// run that returns well-formed Measurements which survive the JSON round trip, the shape sized to
// fixture hosts (working sets from the caches, memory, co-runner counts, the time plan), and the
// adaptive repetition rule. No timing targets: only positive, finite values, and plans.
#include <algorithm>
#include <atomic>
#include <catch2/catch.hpp>
#include <cmath>
#include <regex>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/error.h"
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
  s.repetitions = {6, 8, 5.0};  // some stop at 6 windows, the noisier at the cap
  s.window_ms = 2.0;
  s.warmup_ms = 2.0;
  s.cost_samples = 20;
  s.cost_spacing_us = 200.0;
  s.state_wait_s = 1.0;
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
  int last_step = 0, steps = 0, grew = 0;
  bool monotonic = true;
  std::vector<std::string> labels;
  opt.progress = [&](int step, int n, const std::string& what) {
    monotonic = monotonic && step == last_step + 1 && !what.empty() && step <= n;
    grew += steps != 0 && n > steps ? 1 : 0;
    last_step = step;
    steps = n;
    labels.push_back(what);
  };
  const bool co = opt.cores.size() > 1;
  int plans = 0;
  opt.planned = [&](const SuitePlan& p) {
    ++plans;
    CHECK(p.configurations == 12 + (co ? 32 : 0));
    // The contention probes: before the first of the 4 co-run blocks and after each.
    CHECK(p.max_windows ==
          p.configurations * shape.repetitions.max_windows + (co ? 5 * 2 * kContentionRounds : 0));
  };
  const SuiteResult r = run_suite(opt);
  const auto& m = r.measurements;
  CHECK_FALSE(r.stopped);
  CHECK(monotonic);
  // The total is re-estimated downwards only, but for a co-run block taken again (the probes
  // around it found another DRAM-interference state than the first), which adds its steps.
  // A retake waits for the suite's state, probing: each probe after the first of a wait adds a
  // step too.
  int retaken = 0, waiting = 0;
  for (const auto& n : r.notes) {
    std::smatch hit;
    if (std::regex_search(n, hit, std::regex("(\\d+) co-run block\\(s\\) taken again")))
      retaken = std::stoi(hit[1]);
    if (std::regex_search(n, hit, std::regex("waited ([0-9.]+) s for that state.*?(\\d+) probe")))
      waiting = std::stoi(hit[2]);
  }
  CHECK(grew == retaken + waiting);
  if (co) {
    // One probe before the co-runs, one after each block, two (before, after) for each retake.
    REQUIRE(m.contention.size() == 5u + 2u * static_cast<std::size_t>(retaken));
    CHECK(m.contention.front().when == "before the co-runs");
    for (const auto& p : m.contention) {
      INFO(p.when);
      CHECK(p.cores == std::vector<int>{opt.cores[0], opt.cores[1]});
      CHECK(p.working_set_kb == shape.dram_kb);
      CHECK(p.ratio > 0.0);
      CHECK(p.rounds >= 1);
      CHECK(p.rounds <= kContentionRounds);
      CHECK_FALSE(p.date.empty());
    }
    // Each co-run names the probes around its block: the one before, the one after.
    for (const auto& run : m.runs) {
      if (run.corunners.empty()) {
        CHECK(run.probes.empty());
        continue;
      }
      REQUIRE(run.probes.size() == 2u);
      CHECK(run.probes[0] < run.probes[1]);
      CHECK(static_cast<std::size_t>(run.probes[1]) < m.contention.size());
      CHECK_THAT(m.contention[static_cast<std::size_t>(run.probes[1])].when,
                 Catch::StartsWith("after the co-runs beside"));
    }
  } else {
    CHECK(m.contention.empty());
  }
  CHECK(last_step == steps);
  CHECK(plans == 1);
  // Rounds interleaved: within a block, window w + 1 of any configuration only after window w of
  // every unfinished one; a new block starts again at window 1.
  int last_window = 0;
  for (const auto& what : labels) {
    const auto at = what.find("(window ");
    if (at == std::string::npos) continue;  // a cost block
    const int w = std::stoi(what.substr(at + 8));
    INFO(what);
    CHECK((w == last_window || w == last_window + 1 || w == 1));
    last_window = w;
  }
  CHECK(m.wall_s > 0.0);
  CHECK_FALSE(m.host.date.empty());
  CHECK(r.notes.size() >= 2);  // cores, working sets

  // Windows dropped (a kernel off its core three times) end a measurement with fewer windows
  // than rounds; without any, fewer windows than the cap means the precision was reached.
  int dropped = 0;
  for (const auto& n : r.notes) {
    std::smatch hit;
    if (std::regex_search(n, hit, std::regex("(\\d+) dropped after"))) dropped = std::stoi(hit[1]);
  }
  std::set<std::pair<std::string, double>> alone;
  int coruns = 0;
  for (const auto& k : m.runs) {
    INFO(k.kernel << " " << k.working_set_kb << " KB, " << k.corunners.size() << " co-runners");
    CHECK(std::isfinite(k.ns_per_line));
    CHECK(k.ns_per_line > 0.0);
    CHECK(std::isfinite(k.cv));
    CHECK(k.cv >= 0.0);
    CHECK(k.samples >= 1);
    CHECK(k.samples <= shape.repetitions.max_windows);
    if (k.samples >= 6) {  // a 95 % interval of the median exists
      REQUIRE(k.ci95_pct.has_value());
      CHECK(std::isfinite(*k.ci95_pct));
      CHECK(*k.ci95_pct >= 0.0);
      // Stopped before the cap only when within the precision.
      if (k.samples < shape.repetitions.max_windows && dropped == 0)
        CHECK(*k.ci95_pct <= shape.repetitions.precision_pct);
    } else {
      CHECK_FALSE(k.ci95_pct.has_value());
    }
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

  // preemption: one sample per pair of timed windows (4 pairs in this shape), each the extra time
  // per wake-up (noise may make one negative), or none where every pair was left out (noted).
  if (m.costs_us.count("preemption")) {
    const auto& v = m.costs_us.at("preemption");
    CHECK(v.size() >= 1);
    CHECK(v.size() <= 4);
    CHECK(std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); }));
  } else {
    CHECK(std::any_of(r.notes.begin(), r.notes.end(),
                      [](const std::string& n) { return n.starts_with("preemption"); }));
  }

  nlohmann::json j = m;
  const auto back = calibration::measurements_from_json(j, "test");
  CHECK(nlohmann::json(back) == j);
  CHECK(back.runs.size() == m.runs.size());
  CHECK(back.costs_us.size() == m.costs_us.size());
}

TEST_CASE("a wake-up's gap is the one that began after its cause", "[hw][calibration]") {
  constexpr TimeNs us = kNsPerUs;
  // A spinner's gaps: a host's preemption (100-400 us), then three short ones.
  const std::vector<SpinGap> gaps = {
      {100 * us, 400 * us}, {1030 * us, 1050 * us}, {2000 * us, 2012 * us}, {2999 * us, 3011 * us}};
  std::size_t unmatched = 99;
  // Caused at 300 us, woke inside the host's gap that began before it: not this wake-up's.
  // Caused at 1000 us, woke 35 us later into a gap that began 30 us after it: a slow wake into a
  // busy core, still its own. Caused at 1500 us, woke in no gap: the spinner saw nothing.
  // A timer due at 2000 us whose gap began on time; one due at 3000 us whose gap began 1 us early.
  const std::vector<TimeNs> caused = {300 * us, 1000 * us, 1500 * us, 2000 * us, 3000 * us};
  const std::vector<TimeNs> woke = {350 * us, 1035 * us, 1501 * us, 2003 * us, 3001 * us};
  const std::vector<double> timer = gaps_at(gaps, caused, woke, kWakeLeadNs, unmatched);
  CHECK(timer == std::vector<double>{20.0, 12.0, 12.0});
  CHECK(unmatched == 2);
  // Without a lead (a sample published on another core), the early gap is not its wake-up's.
  const std::vector<double> published = gaps_at(gaps, caused, woke, 0, unmatched);
  CHECK(published == std::vector<double>{20.0, 12.0});
  CHECK(unmatched == 3);
  // No gaps at all: every wake-up unmatched.
  CHECK(gaps_at({}, caused, woke, kWakeLeadNs, unmatched).empty());
  CHECK(unmatched == caused.size());
  CHECK_THROWS_AS(gaps_at(gaps, {1}, woke, 0, unmatched), std::invalid_argument);
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
  CHECK(r.measurements.contention.empty());
}

TEST_CASE("a contention probe on its own: a ratio from paired rounds, two CPUs needed",
          "[hw][calibration]") {
  ContentionOptions opt;
  opt.host.l2_kb = 64;
  opt.host.l3_kb_per_cluster = 128;
  opt.working_set_kb = 256;
  opt.cores = test_cores();
  if (opt.cores.size() < 2) {
    CHECK_THROWS_AS(measure_contention(opt), RunError);
    return;
  }
  const ContentionResult r = measure_contention(opt);
  CHECK(r.probe.cores == opt.cores);
  CHECK(r.probe.working_set_kb == 256);
  CHECK(r.probe.ratio > 0.0);
  CHECK(r.probe.rounds >= 1);
  CHECK(r.probe.rounds <= kContentionRounds);
  CHECK(r.probe.when.empty());
  opt.cores = {opt.cores[0]};
  CHECK_THROWS_WITH(measure_contention(opt),
                    Catch::Contains("needs two CPUs (one measured, one co-runner); 1 given"));
}

namespace {

// The 16-core server VM of /work/shared/measured/xeon16-2026-11-26 (platform-probe.json): 16
// usable CPUs sharing one LLC of 300 MB (307200 KB), L2 2 MB, 125 GB of RAM.
calibration::HostFacts xeon16() {
  calibration::HostFacts h;
  h.cpus = 16;
  h.clusters = 1;
  h.cores_per_cluster = 16;
  h.l1d_kb = 48;
  h.l2_kb = 2048;
  h.l3_kb_per_cluster = 307200;
  return h;
}

// The development VM: 2 CPUs (AMD EPYC), L2 1 MB, L3 32 MB.
calibration::HostFacts vm2() {
  calibration::HostFacts h;
  h.cpus = 2;
  h.cores_per_cluster = 2;
  h.l1d_kb = 32;
  h.l2_kb = 1024;
  h.l3_kb_per_cluster = 32768;
  return h;
}

constexpr double kGb = 1024.0 * 1024.0;  // KB

}  // namespace

TEST_CASE("the suite's shape on a 16-core host with a 300 MB LLC reaches 4x beyond it",
          "[hw][calibration]") {
  const double mem = 120 * kGb;
  for (const bool quick : {true, false}) {
    INFO((quick ? "quick" : "full"));
    const SuiteShape s = shape_for(xeon16(), quick, 16, mem);
    CHECK(s.dram_kb == 4 * 307200.0);  // >= 1.2 GB, no fixed cap
    CHECK(s.dram_kb >= 1.2e6);
    CHECK(s.in_l3_kb == 8192);  // 4x the L2, within the LLC
    CHECK(s.in_l3_kb < 307200);
    CHECK(s.corunner_counts == std::vector<int>{1, 2, 4, 8, 15});
    CHECK(s.notes.empty());
    REQUIRE_FALSE(s.isolation_kb.empty());
    CHECK(s.isolation_kb.front() < 2048);  // below the L2
    const SuitePlan p = plan_suite(s, 16);
    // Each of the 15 co-runners holds its own DRAM set, beside the measuring core's kernels.
    CHECK(p.peak_mb * 1024 >= 15 * s.dram_kb);
    CHECK(p.peak_mb * 1024 <= kMemFraction * mem);
    CHECK(s.repetitions.max_windows >= s.repetitions.min_windows);
    if (quick) {
      CHECK(s.isolation_kb == std::vector<double>{1024});
      CHECK(s.repetitions.precision_pct <= 5.0);
      CHECK(p.configurations == 140);
      CHECK(p.seconds < 180.0);  // the plan's worst case, windows to their cap
    } else {
      CHECK(s.isolation_kb.front() == 16);
      CHECK(s.isolation_kb.back() * 2 > s.dram_kb);  // doubling up to the DRAM set
      CHECK(s.isolation_kb.back() < s.dram_kb);
      CHECK(s.repetitions.precision_pct <= 2.0);
      CHECK(p.seconds < 20 * 60.0);
    }
  }
}

TEST_CASE("the suite refuses a host without memory for a set beyond its LLC", "[hw][calibration]") {
  using Catch::Matchers::Contains;
  // 8 GB MemAvailable, half of it usable: a set 2x the LLC (600 MB) on the measuring core and on
  // each of 15 co-runner cores needs 10828 MB at once.
  CHECK_THROWS_WITH(shape_for(xeon16(), true, 16, 8 * kGb),
                    Contains("not enough memory") && Contains("600 MB") &&
                        Contains("needs 10828 MB") && Contains("4096 MB are available") &&
                        Contains("MemAvailable (8192 MB)"));
  // Between the two: 2x the LLC fits where 4x and 3x do not, and a note says so.
  const SuiteShape s = shape_for(xeon16(), true, 16, 24 * kGb);
  CHECK(s.dram_kb == 2 * 307200.0);
  REQUIRE(s.notes.size() == 1);
  CHECK_THAT(s.notes[0], Contains("2x the LLC, not 4x"));
  CHECK(plan_suite(s, 16).peak_mb * 1024 <= kMemFraction * 24 * kGb);
  // Fewer cores need less: on 4 cores 16 GB holds 4x the LLC (7228 MB at once), 8 GB 2x.
  CHECK(shape_for(xeon16(), true, 4, 16 * kGb).dram_kb == 4 * 307200.0);
  CHECK(shape_for(xeon16(), true, 4, 8 * kGb).dram_kb == 2 * 307200.0);
  // Memory unknown (0): not checked.
  CHECK(shape_for(xeon16(), true, 16, 0.0).dram_kb == 4 * 307200.0);
}

TEST_CASE("the suite's shape on a 2-core VM", "[hw][calibration]") {
  const SuiteShape quick = shape_for(vm2(), true, 2, 20 * kGb);
  CHECK(quick.dram_kb == 4 * 32768.0);
  CHECK(quick.in_l3_kb == 4096);
  CHECK(quick.isolation_kb == std::vector<double>{512});
  CHECK(quick.corunner_counts == std::vector<int>{1});
  const SuitePlan qp = plan_suite(quick, 2);
  CHECK(qp.configurations == 44);
  CHECK(qp.seconds < 180.0);
  const SuiteShape full = shape_for(vm2(), false, 2, 20 * kGb);
  CHECK(full.corunner_counts == std::vector<int>{1});
  REQUIRE_FALSE(full.isolation_kb.empty());
  CHECK(full.isolation_kb.front() == 16);
  CHECK(full.isolation_kb.back() * 2 == full.dram_kb);
  CHECK(full.repetitions.max_windows > quick.repetitions.max_windows);
  CHECK(full.repetitions.precision_pct < quick.repetitions.precision_pct);
  CHECK(plan_suite(full, 2).seconds < 20 * 60.0);
  // Co-runner counts 1, 2, 4, ... and N - 1.
  CHECK(shape_for(vm2(), true, 3, 20 * kGb).corunner_counts == std::vector<int>{1, 2});
  CHECK(shape_for(vm2(), false, 8, 20 * kGb).corunner_counts == std::vector<int>{1, 2, 4, 7});
  CHECK(shape_for(vm2(), true, 1, 20 * kGb).corunner_counts.empty());
}

TEST_CASE("the median's 95 % interval is distribution-free, from order statistics",
          "[hw][calibration]") {
  // Fewer than 6 values: no 95 % interval (the range of 5 covers the median with 93.75 %).
  CHECK(std::isinf(median_ci95_pct({1, 2, 3, 4, 5})));
  CHECK(std::isinf(median_ci95_pct({})));
  // 6 values: the range (96.9 %); half of it, in % of the median 3.5.
  CHECK(median_ci95_pct({6, 1, 5, 2, 4, 3}) == Approx(2.5 / 3.5 * 100));
  // 20 values: x(6) to x(15) (P(B <= 5) = 2.07 %, P(B <= 6) = 5.77 %).
  std::vector<double> v;
  for (int i = 20; i >= 1; --i)
    v.push_back(i);
  CHECK(median_ci95_pct(v) == Approx((15.0 - 6.0) / 2.0 / 10.5 * 100));
  // One stray value moves it by one rank, not by its size.
  std::vector<double> stray(12, 10.0);
  stray[3] = 1000.0;
  CHECK(median_ci95_pct(stray) == 0.0);
  CHECK(std::isinf(median_ci95_pct({0, 0, 0, 0, 0, 0})));
}

TEST_CASE("repetitions stop when the median is precise enough, or at the cap",
          "[hw][calibration]") {
  const RepetitionRule rule{6, 20, 3.0};
  const std::vector<double> tight = {100.0, 101.0, 99.5, 100.5, 99.0, 100.2};  // +-1 %
  CHECK(repetitions_done(tight, 6, rule));
  CHECK_FALSE(repetitions_done({tight.begin(), tight.end() - 1}, 5, rule));  // under 6: no CI
  std::vector<double> noisy = {100.0, 130.0, 80.0, 120.0, 90.0, 110.0};      // +-25 %
  CHECK_FALSE(repetitions_done(noisy, 6, rule));
  CHECK(repetitions_done(noisy, 20, rule));  // the cap
  CHECK(repetitions_done({}, 20, rule));     // every window dropped: still the cap
  CHECK_FALSE(repetitions_done({}, 19, rule));
  // More windows narrow it: a spread of +-10 % around 100 in a repeating pattern stops before
  // the cap once enough of it sits near the middle.
  const RepetitionRule loose{6, 200, 3.0};
  std::vector<double> w;
  int stopped_at = 0;
  for (int round = 1; round <= 200 && !stopped_at; ++round) {
    const double pattern[] = {90, 95, 98, 99, 100, 100, 101, 102, 105, 110};
    w.push_back(pattern[(round * 7) % 10]);
    if (repetitions_done(w, round, loose)) stopped_at = round;
  }
  CHECK(stopped_at > 6);
  CHECK(stopped_at < 200);
  CHECK(median_ci95_pct(w) <= 3.0);
  // min_windows above 6 holds it back even when precise.
  CHECK_FALSE(repetitions_done(tight, 6, RepetitionRule{9, 20, 3.0}));
}

TEST_CASE("measurements without ci95_pct still load, and with it round-trip", "[hw][calibration]") {
  const auto doc = nlohmann::json::parse(test::slurp(std::string(ROSGUARD_TEST_SOURCE_DIR) +
                                                     "/tests/sim/fixtures/calibration-vm.json"));
  auto m = calibration::measurements_from_json(doc.at("measurements"), "fixture");
  REQUIRE_FALSE(m.runs.empty());
  for (const auto& r : m.runs)
    CHECK_FALSE(r.ci95_pct.has_value());
  m.runs[0].ci95_pct = 2.5;
  const nlohmann::json j = m;
  CHECK(j.at("runs")[0].at("ci95_pct") == 2.5);
  CHECK_FALSE(j.at("runs")[1].contains("ci95_pct"));
  const auto back = calibration::measurements_from_json(j, "test");
  REQUIRE(back.runs[0].ci95_pct.has_value());
  CHECK(*back.runs[0].ci95_pct == 2.5);
  CHECK_FALSE(back.runs[1].ci95_pct.has_value());
  CHECK(nlohmann::json(back) == j);
}

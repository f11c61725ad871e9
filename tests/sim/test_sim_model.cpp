// The pure parts of the sim backend (no SystemC): the memory model, the cost distributions,
// profile and platform parsing, and the provenance of every number in the Orin platform.
#include <catch2/catch.hpp>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "nodes/costs.h"
#include "platform/contention.h"
#include "platform/residency.h"
#include "platform/sim_platform.h"
#include "sim_test_util.h"
#include "workload/profile.h"

using namespace rosguard;
using namespace rosguard::sim;
using json = nlohmann::json;

namespace {

json read_json(const std::string& rel) {
  std::ifstream in(test::source_dir() / rel);
  return json::parse(in);
}

SimPlatform orin() {
  const json doc = read_json("scenarios/platforms/orin-agx.json");
  return parse_sim_platform(build_platform(doc, "scenarios/platforms/orin-agx.json"));
}

WorkloadProfile profile(const std::string& name) {
  const std::string file = "scenarios/workloads/" + name + ".json";
  return parse_profile({name, file, read_json(file)}, orin(), file, "/sim");
}

// Steady-state instructions per ns of each demand (all on the given clusters).
std::vector<double> speeds(const ContentionModel& m, const std::vector<CoreDemand>& d) {
  const MemoryState st = m.solve(d);
  std::vector<double> out;
  for (std::size_t i = 0; i < d.size(); ++i)
    out.push_back(m.rates(*d[i].phase, st.l3_hit[i], d[i].cluster, st, st.slc_hit[i]).inst_per_ns);
  return out;
}

CoreDemand demand(const WorkloadProfile& w, int cluster) {
  return {cluster, &w.phases[0], &w, true, &w.phases[0]};
}

}  // namespace

TEST_CASE("memory model: the solved latencies are a fixed point of the traffic they cause",
          "[sim][memory]") {
  const SimPlatform p = orin();
  const ContentionModel m(p);
  const WorkloadProfile br = profile("bandwidth_read");
  const std::vector<CoreDemand> d = {demand(br, 0), demand(br, 0)};
  const MemoryState st = m.solve(d);
  double bytes = 0.0;
  for (std::size_t i = 0; i < d.size(); ++i) {
    const CoreRates r = m.rates(*d[i].phase, st.l3_hit[i], 0, st, st.slc_hit[i]);
    bytes += (r.refill_per_ns + r.wb_per_ns) * p.line_bytes;
  }
  const double util = bytes / ContentionModel::bytes_per_ns(p.l3.bandwidth_mbps);
  CHECK(st.l3_util[0] == Approx(util).epsilon(1e-6));
  CHECK(st.l3_ns[0] == Approx(m.l3_latency(util)).epsilon(1e-6));
  CHECK(st.l3_util[1] == 0.0);
  // Deterministic: the same demands give the same doubles.
  CHECK(m.solve(d) == st);
}

TEST_CASE("memory model: the DRAM counts a write-back at dram.writeback_weight of a refill",
          "[sim][memory]") {
  SimPlatform p = orin();
  p.slc.reset();  // every L3 miss goes to DRAM
  // A reader and a writer streaming 2 MB each through one 2 MB L3: both miss on every line.
  const WorkloadProfile br = profile("bandwidth_read");
  const WorkloadProfile bw = profile("bandwidth_write");
  const std::vector<CoreDemand> d = {demand(br, 0), demand(bw, 0)};
  const auto dram_util = [&](double weight) {
    p.dram.writeback_weight = weight;
    const ContentionModel m(p);
    const MemoryState st = m.solve(d);
    double reads = 0.0, wbs = 0.0;
    for (std::size_t i = 0; i < d.size(); ++i) {
      const CoreRates r = m.rates(*d[i].phase, st.l3_hit[i], 0, st, st.slc_hit[i]);
      CHECK(r.dram_lines_per_ns == Approx(r.l3_refill_per_ns + r.dram_wb_per_ns));
      reads += r.l3_refill_per_ns;
      wbs += r.dram_wb_per_ns;
    }
    REQUIRE(wbs > 0.0);
    // The utilisation is the weighted traffic over the bandwidth, at the fixed point.
    CHECK(st.dram_util == Approx((reads + weight * wbs) * p.line_bytes /
                                 ContentionModel::bytes_per_ns(p.dram.bandwidth_mbps))
                              .epsilon(1e-6));
    return st.dram_util;
  };
  const double one = dram_util(1.0);
  CHECK(dram_util(0.5) < one);
  CHECK(dram_util(2.0) > one);
}

TEST_CASE("memory model: co-runners in a cluster slow each other, across clusters far less",
          "[sim][memory]") {
  const SimPlatform p = orin();
  const ContentionModel m(p);
  const WorkloadProfile br = profile("bandwidth_read");
  const double alone = speeds(m, {demand(br, 0)})[0];
  const double same = speeds(m, {demand(br, 0), demand(br, 0)})[0];
  const double other = speeds(m, {demand(br, 0), demand(br, 1)})[0];
  const double three = speeds(m, {demand(br, 0), demand(br, 0), demand(br, 0)})[0];
  CHECK(alone / same > 1.3);    // shared L3 bandwidth and capacity
  CHECK(alone / other < 1.05);  // only the DRAM is shared
  CHECK(three < same);
}

TEST_CASE("memory model: the L3 is shared as LRU shares it, by the phases' miss-ratio curves",
          "[sim][memory]") {
  const SimPlatform p = orin();
  const ContentionModel m(p);
  // Alone, a phase holds the whole L3: its hit ratio is its curve's at the L3's capacity. That
  // is the profile's isolation l3_hit for a derived curve (made to keep it); a measured curve
  // (the SD-VBS profiles: per phase) keeps its own, which l3_hit averages over the phases.
  for (const char* name : {"bandwidth_read", "bandwidth_write", "latency", "disparity", "mser",
                           "sift", "stitch", "tracking"}) {
    const WorkloadProfile w = profile(name);
    INFO(name);
    const double hit = m.solve(std::vector<CoreDemand>{demand(w, 0)}).l3_hit[0];
    CHECK(hit == Approx(1.0 - w.phases[0].mrc.miss_ratio(p.l3.capacity_kb)).margin(1e-9));
    if (std::string(name).rfind("bandwidth", 0) == 0 || std::string(name) == "latency")
      CHECK(hit == Approx(w.l3_hit).margin(1e-9));
  }
  // Two 2 MB streams in one 2 MB L3: under LRU each evicts the other's lines before their
  // reuse, and both miss on every line (the former (share / footprint)^0.35 kept 76 %).
  const WorkloadProfile br = profile("bandwidth_read");
  const MemoryState two = m.solve(std::vector<CoreDemand>{demand(br, 0), demand(br, 0)});
  CHECK(two.l3_hit[0] == 0.0);
  CHECK(two.l3_hit[1] == 0.0);
  // Working sets that fit together keep their hits.
  WorkloadProfile small = profile("mser");
  small.footprint_kb = 512;
  for (Phase& ph : small.phases)
    ph.mrc = derived_mrc(0.0, small.footprint_kb, small.l3_hit, p);
  const MemoryState fits = m.solve(std::vector<CoreDemand>{demand(small, 0), demand(small, 0)});
  CHECK(fits.l3_hit[0] == Approx(small.l3_hit));
  // A throttled co-runner's lines have been evicted: the L3 is the other's alone.
  CoreDemand idle = demand(br, 0);
  idle.resident = false;
  idle.phase = nullptr;
  CHECK(m.solve(std::vector<CoreDemand>{demand(br, 0), idle}).l3_hit[0] == Approx(br.l3_hit));
  // A stream takes most of the L3 from a light co-runner, which keeps the share its insertions
  // earn at the common eviction age. (sift's measured curve has no hits within 2 MB at all, so
  // the co-runner here is a lighter copy of it with a derived curve that has some.)
  WorkloadProfile sift = profile("sift");
  sift.l3_hit = 0.5;
  for (Phase& ph : sift.phases)
    ph.mrc = derived_mrc(0.0, sift.footprint_kb, sift.l3_hit, p);
  const std::vector<CoreDemand> mixed_d = {demand(br, 0), demand(sift, 0)};
  const MemoryState mixed = m.solve(mixed_d);
  const std::vector<double> occ = m.occupancies(mixed_d);
  CHECK(occ[0] + occ[1] == Approx(p.l3.capacity_kb));
  CHECK(occ[0] > 4 * occ[1]);
  CHECK(mixed.l3_hit[1] < sift.l3_hit);
  CHECK(mixed.l3_hit[1] > 0.0);
  // The 2 MB stream needs 2 MB - 256 KB of an L3 exclusive of the 256 KB L2: beside the light
  // co-runner it keeps its hits. Were the L3 not exclusive, it would need all 2 MB, and the
  // co-runner's few lines would make it miss on every line (LRU's cliff).
  CHECK(mixed.l3_hit[0] == Approx(br.l3_hit));
  SimPlatform inclusive = p;
  inclusive.l3.exclusive_of_l2 = false;
  const WorkloadProfile br_incl =
      parse_profile({"bandwidth_read", "scenarios/workloads/bandwidth_read.json",
                     read_json("scenarios/workloads/bandwidth_read.json")},
                    inclusive, "bandwidth_read.json", "/sim");
  const WorkloadProfile sift_incl = parse_profile(
      {"sift", "scenarios/workloads/sift.json", read_json("scenarios/workloads/sift.json")},
      inclusive, "sift.json", "/sim");
  CHECK(ContentionModel(inclusive)
            .solve(std::vector<CoreDemand>{demand(br_incl, 0), demand(sift_incl, 0)})
            .l3_hit[0] == 0.0);
  // Another cluster does not count.
  const MemoryState apart = m.solve(std::vector<CoreDemand>{demand(br, 0), demand(br, 1)});
  CHECK(apart.l3_hit[0] == Approx(br.l3_hit));
}

TEST_CASE("memory model: misses in flight are bounded per core and per cluster (Little's law)",
          "[sim][memory]") {
  SimPlatform p = orin();
  const WorkloadProfile lat = profile("latency");  // one load in flight, every one to the DRAM
  WorkloadProfile wide = lat;
  wide.phases[0].mlp = 16;
  // Per core: an mlp above the core's buffers is cut to them.
  p.mshr.per_core = 4;
  p.mshr.per_cluster = 64;
  const ContentionModel cut(p);
  WorkloadProfile four = lat;
  four.phases[0].mlp = 4;
  CHECK(speeds(cut, {demand(wide, 0)})[0] == Approx(speeds(cut, {demand(four, 0)})[0]));
  // Per cluster: four such cores keep at most per_cluster L3 misses in flight together.
  p.mshr.per_core = 16;
  p.mshr.per_cluster = 8;
  const ContentionModel bound(p);
  const std::vector<CoreDemand> d(4, demand(wide, 0));
  const MemoryState st = bound.solve(d);
  REQUIRE(st.mlp_scale[0] < 1.0);
  double inflight = 0.0;
  for (std::size_t i = 0; i < d.size(); ++i)
    inflight += bound.rates(wide.phases[0], st.l3_hit[i], 0, st, st.slc_hit[i]).l3_refill_per_ns *
                bound.miss_latency(st.slc_hit[i], st.dram_ns);
  CHECK(inflight == Approx(p.mshr.per_cluster).epsilon(1e-6));
  CHECK(st.mlp_scale[1] == 1.0);
  // Without the bound they would have more in flight, and progress faster.
  p.mshr.per_cluster = 1024;
  const ContentionModel free(p);
  const std::vector<double> unbounded = speeds(free, d);
  CHECK(unbounded[0] > speeds(bound, d)[0]);
  CHECK(free.solve(d).mlp_scale[0] == 1.0);
}

TEST_CASE("memory model: a system-level cache below the L3s takes what they miss",
          "[sim][memory]") {
  const SimPlatform p = orin();
  REQUIRE(p.slc);
  const WorkloadProfile br = profile("bandwidth_read");
  const std::vector<CoreDemand> pair = {demand(br, 0), demand(br, 0)};
  // Two 2 MB streams thrash their cluster's 2 MB L3, and fit together in a 4 MB SLC.
  SimPlatform big = p;
  big.slc->capacity_kb = 4096;
  const ContentionModel with(big);
  const MemoryState st = with.solve(pair);
  // Each hits there as it does alone in its L3 (br.l3_hit: the lines it never reuses miss).
  CHECK(st.l3_hit[0] == 0.0);
  CHECK(st.slc_hit[0] == Approx(br.l3_hit));
  CHECK(st.slc_hit[1] == Approx(br.l3_hit));
  const CoreRates r = with.rates(*pair[0].phase, st.l3_hit[0], 0, st, st.slc_hit[0]);
  CHECK(r.l3_refill_per_ns == Approx(r.refill_per_ns));  // every refill misses the L3 ...
  CHECK(r.dram_lines_per_ns ==                           // ... what the SLC misses reaches DRAM
        Approx((1.0 - st.slc_hit[0]) * r.refill_per_ns + r.wb_per_ns));
  // They progress faster than with the L3 misses going to the DRAM.
  SimPlatform none = p;
  none.slc.reset();
  const ContentionModel without(none);
  CHECK(speeds(with, pair)[0] > 1.2 * speeds(without, pair)[0]);
  CHECK(st.dram_util < without.solve(pair).dram_util);
  // In a 2 MB SLC they thrash again; in one of 0 KB nothing hits, and the model solves to the
  // same doubles as without an SLC (the miss latency is then the DRAM's exactly).
  SimPlatform small = p;
  small.slc->capacity_kb = 2048;
  CHECK(ContentionModel(small).solve(pair).slc_hit[0] == 0.0);
  SimPlatform zero = p;
  zero.slc->capacity_kb = 0;
  const MemoryState z = ContentionModel(zero).solve(pair);
  const MemoryState n = without.solve(pair);
  CHECK(z.slc_hit == std::vector<double>{0.0, 0.0});
  CHECK(z.l3_ns == n.l3_ns);
  CHECK(z.dram_ns == n.dram_ns);
  CHECK(z.mlp_scale == n.mlp_scale);
  // The SLC is shared by all clusters: a third stream on another cluster takes its part.
  const std::vector<CoreDemand> three = {demand(br, 0), demand(br, 0), demand(br, 1)};
  const MemoryState t = with.solve(three);
  CHECK(t.l3_hit[2] == Approx(br.l3_hit));   // alone in its L3: it hits there ...
  CHECK(t.slc_hit[0] == Approx(br.l3_hit));  // ... so the pair still fits in the SLC
  const std::vector<CoreDemand> spread = {demand(br, 0), demand(br, 0), demand(br, 1),
                                          demand(br, 1)};
  const MemoryState s4 = with.solve(spread);
  CHECK(s4.slc_hit[0] == 0.0);  // four 1792 KB streams of L3 misses exceed 4 MB: LRU thrashes
}

namespace {

// One residency step as the memory system takes it: occupancies to `t`, solve with their hit
// ratios, rates; returns the state.
MemoryState step(L3Residency& res, const ContentionModel& m, double t,
                 const std::vector<CoreDemand>& d) {
  res.advance(t, d);
  MemoryState st = m.solve(d, res.hits());
  res.set_rates(d, st);
  return st;
}

CoreDemand throttled(CoreDemand d) {
  d.resident = false;
  d.phase = nullptr;
  return d;
}

}  // namespace

TEST_CASE("L3 residency: a throttled core loses its lines at the rate its co-runner inserts",
          "[sim][memory][residency]") {
  const SimPlatform p = orin();
  const ContentionModel m(p);
  const WorkloadProfile mser = profile("mser");
  const WorkloadProfile br = profile("bandwidth_read");
  const double line_kb = p.line_bytes / 1024.0;
  L3Residency res(m, p);
  // Both run: warm at the natural partition.
  const std::vector<CoreDemand> both = {demand(mser, 0), demand(br, 0)};
  const MemoryState shared = step(res, m, 0.0, both);
  const std::vector<double> occ = m.occupancies(both);
  CHECK(res.resident_kb(0) == occ[0]);
  CHECK(res.resident_kb(0) < p.l3.capacity_kb / 2);
  CHECK(shared.l3_hit == m.steady_hits(both));  // warm = the steady state
  // mser throttled: its target is 0, the stream's the whole L3; the stream inserts a line per
  // L3 miss, each evicting one of mser's.
  const std::vector<CoreDemand> thr = {throttled(demand(mser, 0)), demand(br, 0)};
  const MemoryState st = step(res, m, 1000.0, thr);
  CHECK(res.target_kb(0) == 0.0);
  const CoreRates stream = m.rates(br.phases[0], res.hits()[1], 0, st, st.slc_hit[1]);
  CHECK(stream.l3_refill_per_ns > 0.0);
  CHECK(res.rate_kb_per_ns(0) == Approx(-line_kb * stream.l3_refill_per_ns));
  CHECK(res.rate_kb_per_ns(1) == Approx(line_kb * stream.l3_refill_per_ns));  // it grows
  const double before = res.resident_kb(0);
  const double dt = 0.25 * before / -res.rate_kb_per_ns(0);  // a quarter of its lines
  step(res, m, 1000.0 + dt, thr);
  CHECK(res.resident_kb(0) == Approx(0.75 * before));
  CHECK(res.resident_kb(1) == Approx(occ[1] + 0.25 * before));  // the stream took the space
  // Long enough, and nothing of mser is left.
  step(res, m, 1e9, thr);
  CHECK(res.resident_kb(0) == 0.0);
  CHECK(res.hits()[0] == 0.0);
}

TEST_CASE("L3 residency: alone, or beside an idle co-runner, a throttled core keeps its lines",
          "[sim][memory][residency]") {
  const SimPlatform p = orin();
  const ContentionModel m(p);
  const WorkloadProfile mser = profile("mser");
  L3Residency res(m, p);
  step(res, m, 0.0, {demand(mser, 0), throttled(demand(mser, 0))});
  CHECK(res.resident_kb(0) == p.l3.capacity_kb);  // alone it fills the L3
  const std::vector<CoreDemand> idle = {throttled(demand(mser, 0)), throttled(demand(mser, 0))};
  step(res, m, 1000.0, idle);
  CHECK(res.rate_kb_per_ns(0) == 0.0);
  step(res, m, 1e9, idle);
  CHECK(res.resident_kb(0) == p.l3.capacity_kb);
  // A co-runner on another cluster inserts into its own L3.
  const WorkloadProfile br = profile("bandwidth_read");
  step(res, m, 2e9, {throttled(demand(mser, 0)), demand(br, 1)});
  CHECK(res.rate_kb_per_ns(0) == 0.0);
}

TEST_CASE(
    "L3 residency: after resuming a core refills at its own miss rate and its progress "
    "recovers",
    "[sim][memory][residency]") {
  const SimPlatform p = orin();
  const ContentionModel m(p);
  const WorkloadProfile mser = profile("mser");
  const WorkloadProfile br = profile("bandwidth_read");
  const double line_kb = p.line_bytes / 1024.0;
  L3Residency res(m, p);
  const std::vector<CoreDemand> alone = {demand(mser, 0)};
  const MemoryState warm_st = step(res, m, 0.0, alone);
  const double warm_hit = res.hits()[0];
  CHECK(warm_hit == Approx(1.0 - mser.phases[0].mrc.miss_ratio(p.l3.capacity_kb)));
  const double warm = m.rates(mser.phases[0], warm_hit, 0, warm_st, warm_st.slc_hit[0]).inst_per_ns;
  // Lose most of it to a stream on core 1 while throttled, then resume with the stream idle.
  const std::vector<CoreDemand> thr = {throttled(demand(mser, 0)), demand(br, 0)};
  step(res, m, 1.0, thr);
  const double lose = 0.9 * p.l3.capacity_kb / -res.rate_kb_per_ns(0);
  const std::vector<CoreDemand> back = {demand(mser, 0), throttled(demand(br, 0))};
  MemoryState st = step(res, m, 1.0 + lose, back);
  REQUIRE(res.resident_kb(0) == Approx(0.1 * p.l3.capacity_kb));
  const double hit = res.hits()[0];
  CHECK(hit == Approx(1.0 - mser.phases[0].mrc.miss_ratio(0.1 * p.l3.capacity_kb)));
  CHECK(hit < warm_hit);
  const CoreRates cold = m.rates(mser.phases[0], hit, 0, st, st.slc_hit[0]);
  CHECK(cold.inst_per_ns < warm);
  CHECK(cold.l3_refill_per_ns >
        m.rates(mser.phases[0], warm_hit, 0, warm_st, warm_st.slc_hit[0]).l3_refill_per_ns);
  // Refill: every L3 miss inserts a line of its own (the co-runner's lines are older).
  CHECK(res.rate_kb_per_ns(0) == Approx(line_kb * cold.l3_refill_per_ns));
  // Stepping level by level (as the memory system re-solves), it gets warm again, and its
  // progress rate with it; the speed never falls on the way.
  double t = 1.0 + lose, speed = cold.inst_per_ns;
  int steps = 0;
  for (; steps < 10000 && res.resident_kb(0) < p.l3.capacity_kb; ++steps) {
    const double next = res.set_rates(back, st);
    REQUIRE(next >= 0.0);
    t += std::max(next, 1.0);
    st = step(res, m, t, back);
    const double now = m.rates(mser.phases[0], res.hits()[0], 0, st, st.slc_hit[0]).inst_per_ns;
    CHECK(now >= speed);
    speed = now;
  }
  CHECK(res.resident_kb(0) == p.l3.capacity_kb);
  CHECK(speed == Approx(warm));
  // One re-solve per capacity level crossed, of mser (refilling) or of the idle stream (whose
  // lines mser's insertions evict).
  CHECK(steps <= 2 * (L3Residency::kLevels + 1));
}

TEST_CASE("memory model: saturation is bounded (latency finite, utilisation below 1)",
          "[sim][memory]") {
  const SimPlatform p = orin();
  const ContentionModel m(p);
  const WorkloadProfile br = profile("bandwidth_read");
  std::vector<CoreDemand> d;
  for (int i = 0; i < 4; ++i)
    d.push_back(demand(br, 0));
  const MemoryState st = m.solve(d);
  CHECK(st.l3_util[0] < 1.0);
  CHECK(st.dram_util > 0.0);
  CHECK(st.dram_util < 1.0);
  CHECK(std::isfinite(st.l3_ns[0]));
  CHECK(std::isfinite(st.dram_ns));
  CHECK(speeds(m, d)[0] > 0.0);
}

TEST_CASE("cost distributions: seeded, reproducible, within their bounds", "[sim][costs]") {
  Distribution n;
  n.kind = Distribution::Kind::Normal;
  n.mean_us = 15;
  n.spread = 2;
  n.min_us = 13.5;
  n.max_us = 17.5;
  CostStream a(n, 42), b(n, 42), c(n, 43);
  bool differs = false;
  for (int i = 0; i < 2000; ++i) {
    const double x = a.draw_us();
    CHECK(x == b.draw_us());
    differs |= x != c.draw_us();
    CHECK(x >= 13.5);
    CHECK(x <= 17.5);
  }
  CHECK(differs);

  Distribution l;
  l.kind = Distribution::Kind::Lognormal;
  l.min_us = 40;
  l.mean_us = 44;
  l.spread = 0.5;
  l.max_us = 60;
  CostStream s(l, 7);
  std::vector<double> v;
  for (int i = 0; i < 20001; ++i)
    v.push_back(s.draw_us());
  std::sort(v.begin(), v.end());
  CHECK(v.front() > 40);
  CHECK(v.back() <= 60);
  CHECK(v[v.size() / 2] == Approx(44).epsilon(0.01));  // median_us is the median
  CHECK(stream_seed(1, "nrt0/pmc_callback") != stream_seed(1, "nrt0/publish"));
}

TEST_CASE("kernel profiles: the streams refill every line beyond the L2, the chase a share",
          "[sim][profile]") {
  SimPlatform p = orin();
  p.l2_kb = 1024.0;
  const KernelModel model{0.5, 0.7, 8.0};  // ns_per_line_l2, ns_per_line_l3, mlp
  const auto phase = [&](const char* kernel, double ws_kb) {
    return kernel_profile(kernel, kernel, model, ws_kb, 1.0, p).phases.at(0);
  };
  const auto ns_per_line = [&](const Phase& ph) { return 1.0 / (ph.base_ipc * p.freq_ghz()); };
  // Within the L2: no refills, the L2 time.
  for (const char* k : {"bandwidth_read", "bandwidth_write", "latency"}) {
    INFO(k);
    CHECK(phase(k, 1024).refill_pki == 0.0);
    CHECK(ns_per_line(phase(k, 1024)) == Approx(0.5));
  }
  // Beyond it a sequential stream misses the L2 on every line; a write stream writes each back.
  CHECK(phase("bandwidth_read", 2048).refill_pki == 1000.0);
  CHECK(phase("bandwidth_read", 2048).wb_pki == 0.0);
  CHECK(phase("bandwidth_write", 2048).wb_pki == 1000.0);
  CHECK(ns_per_line(phase("bandwidth_read", 4096)) == Approx(0.7));
  // The random-order chase hits the L2 with the share of its lines the L2 holds.
  CHECK(phase("latency", 2048).refill_pki == Approx(500.0));
  CHECK(ns_per_line(phase("latency", 2048)) == Approx(0.5 * 0.5 + 0.5 * 0.7));
  CHECK(phase("latency", 4096).refill_pki == Approx(750.0));
  CHECK(phase("latency", 131072).refill_pki == Approx(1000.0 * (1.0 - 1.0 / 128.0)));
}

TEST_CASE("profiles: fractions must add up to 1, named by file and path", "[sim][profile]") {
  json doc = read_json("scenarios/workloads/mser.json");
  doc["sim"]["phases"][0]["fraction"] = 0.5;
  try {
    parse_profile({"mser", "w.json", doc}, orin(), "w.json", "/sim");
    FAIL("no error");
  } catch (const InputError& e) {
    CHECK(e.file() == "w.json");
    CHECK(e.json_path() == "/sim/phases");
  }
  const WorkloadProfile p = profile("mser");
  WorkloadRun run(p);
  double total = 0.0;
  std::size_t segments = 0;
  do {
    total += run.remaining_in_segment();
    run.retire(run.remaining_in_segment());
    ++segments;
  } while (run.next_segment());
  CHECK(segments == p.segments());
  CHECK(total == Approx(p.instructions));
  CHECK(run.runs_completed() == 1);
  CHECK(run.retired_total() == Approx(p.instructions));
}

TEST_CASE("platforms: sim needs a memory model and costs", "[sim][platform]") {
  json doc = read_json("scenarios/platforms/orin-agx.json");
  doc.erase("memory");
  try {
    parse_sim_platform(build_platform(doc, "p.json"));
    FAIL("no error");
  } catch (const InputError& e) {
    CHECK(e.file() == "p.json");
    CHECK(e.json_path() == "/memory");
  }
  doc = read_json("scenarios/platforms/orin-agx.json");
  doc["costs"]["message_latency_us"]["median_us"] = 30;  // below its location
  CHECK_THROWS_AS(parse_sim_platform(build_platform(doc, "p.json")), InputError);
}

TEST_CASE("orin-agx: every object that holds numbers says where they come from",
          "[sim][platform]") {
  const json doc = read_json("scenarios/platforms/orin-agx.json");
  std::vector<std::string> missing;
  std::function<void(const json&, const std::string&, bool)> walk =
      [&](const json& j, const std::string& path, bool sourced) {
        if (!j.is_object()) return;
        const bool here = j.contains("source");
        bool numbers = false;
        for (const auto& [k, v] : j.items())
          numbers |= v.is_number();
        if (numbers && !here && !sourced) missing.push_back(path.empty() ? "/" : path);
        for (const auto& [k, v] : j.items())
          walk(v, path + "/" + k, false);
      };
  walk(doc, "", false);
  INFO("objects with numbers and no source: " << json(missing).dump());
  CHECK(missing.empty());
  // The costs the chain needs, and the sim PMU events.
  for (const char* k : {"pmc_callback_us", "publish_us", "message_latency_us",
                        "controller_callback_us", "throttle_activation_us", "external_read_us"})
    CHECK(doc["costs"].contains(k));
}

TEST_CASE("workloads: the seven paper workloads have a sourced sim profile", "[sim][profile]") {
  for (const char* name :
       {"bandwidth_read", "bandwidth_write", "disparity", "mser", "sift", "stitch", "tracking"}) {
    INFO(name);
    const json doc = read_json(std::string("scenarios/workloads/") + name + ".json");
    REQUIRE(doc.contains("sim"));
    CHECK(doc["sim"].contains("source"));
    CHECK(doc["reference"].contains("ipc"));
    CHECK_NOTHROW(profile(name));
  }
}

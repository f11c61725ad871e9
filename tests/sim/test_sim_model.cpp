// The pure parts of the sim backend (no SystemC): the memory model, the cost distributions,
// profile and platform parsing, and the provenance of every number in the Orin platform.
#include <catch2/catch.hpp>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "nodes/costs.h"
#include "platform/contention.h"
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
  return parse_profile({name, file, read_json(file)}, file, "/sim");
}

// Steady-state instructions per ns of each demand (all on the given clusters).
std::vector<double> speeds(const ContentionModel& m, const std::vector<CoreDemand>& d) {
  const MemoryState st = m.solve(d);
  std::vector<double> out;
  for (std::size_t i = 0; i < d.size(); ++i)
    out.push_back(
        m.rates(*d[i].phase, d[i].l3_hit, d[i].cluster, st.capacity_factor[i], st).inst_per_ns);
  return out;
}

CoreDemand demand(const WorkloadProfile& w, int cluster) {
  return {cluster, &w.phases[0], w.l3_hit, w.footprint_kb, true, &w.phases[0]};
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
    const CoreRates r = m.rates(*d[i].phase, d[i].l3_hit, 0, st.capacity_factor[i], st);
    bytes += (r.refill_per_ns + r.wb_per_ns) * p.line_bytes;
  }
  const double util = bytes / ContentionModel::bytes_per_ns(p.l3.bandwidth_mbps);
  CHECK(st.l3_util[0] == Approx(util).epsilon(1e-6));
  CHECK(st.l3_ns[0] == Approx(m.l3_latency(util)).epsilon(1e-6));
  CHECK(st.l3_util[1] == 0.0);
  // Deterministic: the same demands give the same doubles.
  CHECK(m.solve(d) == st);
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

TEST_CASE("memory model: the L3 is shared by pressure when the resident footprints exceed it",
          "[sim][memory]") {
  const SimPlatform p = orin();
  const ContentionModel m(p);
  WorkloadProfile small = profile("mser");
  small.footprint_kb = 512;
  const MemoryState fits = m.solve(std::vector<CoreDemand>{demand(small, 0), demand(small, 0)});
  CHECK(fits.capacity_factor[0] == 1.0);
  WorkloadProfile big = small;
  big.footprint_kb = 2048;
  // Equal pressure: half the L3 each.
  const MemoryState over = m.solve(std::vector<CoreDemand>{demand(big, 0), demand(big, 0)});
  CHECK(over.capacity_factor[0] == Approx(std::pow(0.5, p.l3.capacity_exponent)));
  CHECK(over.capacity_factor[1] == over.capacity_factor[0]);
  // A throttled co-runner's lines have been evicted: the L3 is the other's alone.
  CoreDemand idle = demand(big, 0);
  idle.resident = false;
  idle.phase = nullptr;
  const MemoryState one = m.solve(std::vector<CoreDemand>{demand(big, 0), idle});
  CHECK(one.capacity_factor[0] == 1.0);
  // A stream evicts a light co-runner; the light one barely disturbs the stream.
  const WorkloadProfile br = profile("bandwidth_read");
  const WorkloadProfile sift = profile("sift");
  const MemoryState mixed = m.solve(std::vector<CoreDemand>{demand(br, 0), demand(sift, 0)});
  CHECK(mixed.capacity_factor[0] > 0.98);
  CHECK(mixed.capacity_factor[1] < 0.5);
  // Another cluster does not count.
  const MemoryState apart = m.solve(std::vector<CoreDemand>{demand(br, 0), demand(br, 1)});
  CHECK(apart.capacity_factor[0] == 1.0);
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

TEST_CASE("profiles: fractions must add up to 1, named by file and path", "[sim][profile]") {
  json doc = read_json("scenarios/workloads/mser.json");
  doc["sim"]["phases"][0]["fraction"] = 0.5;
  try {
    parse_profile({"mser", "w.json", doc}, "w.json", "/sim");
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

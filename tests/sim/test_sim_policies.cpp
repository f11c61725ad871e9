// MemGuard and MemPol in the simulator: the mechanisms hold a DRAM-bound nRT node near its
// budget, count their throttles, and protect the RT node, against an unregulated co-run.
#include <catch2/catch.hpp>
#include <cmath>

#include "metric/metric.h"
#include "platform/contention.h"
#include "platform/sim_platform.h"
#include "sim_test_util.h"
#include "workload/profile.h"

using namespace rosguard;
using json = nlohmann::json;

namespace {

json scenario(const json& regulation) {
  return {{"name", "policies"},
          {"nodes",
           {{"controller", {{"core", 0}}},
            {"rt", {{{"name", "rt0"}, {"core", 1}, {"workload", "mser"}}}},
            {"nrt", {{{"name", "nrt0"}, {"core", 2}, {"workload", "bandwidth_read"}}}}}},
          {"regulation", regulation}};
}

// The nRT workload's unregulated traffic, bytes per ns, in its most memory-hungry phase.
double unregulated_rate(const Scenario& s) {
  const sim::SimPlatform plat = sim::parse_sim_platform(s.platform);
  const sim::WorkloadProfile prof = sim::parse_profile(s.nodes.nrt[0].workload, plat, "w", "/sim");
  const sim::ContentionModel model(plat);
  double rate = 0.0;
  for (const auto& ph : prof.phases) {
    const sim::CoreDemand d{plat.cluster_of(s.nodes.nrt[0].core), &ph, &prof, true, &ph};
    const auto st = model.solve({&d, 1});
    const auto r = model.rates(ph, st.l3_hit[0], d.cluster, st, st.slc_hit[0]);
    rate = std::max(rate, (r.refill_per_ns + r.wb_per_ns) * plat.line_bytes);
  }
  return rate;
}

double rt_slowdown(const json& rep) {
  return rep["rt"][0]["time_us"].get<double>() /
         rep["isolation"]["rt:rt0"]["time_us"].get<double>();
}

std::vector<double> samples_of(const json& rep, const std::string& kind) {
  std::vector<double> out;
  for (const auto& o : rep["samples"])
    if (o[0] == kind) out.push_back(o[1].get<double>());
  return out;
}

}  // namespace

TEST_CASE(
    "memguard: the overflow interrupt holds a DRAM-bound nRT node to its budget per 1 ms "
    "period plus the traffic of one interrupt latency, and protects the RT node",
    "[sim][policies][memguard]") {
  test::TempDir dir;
  const auto none = test::load_points_json(scenario({{"policy", "none"}}), dir.path()).at(0);
  const auto mg =
      test::load_points_json(scenario({{"policy", "memguard"}, {"budget_mbps", 2000}}), dir.path())
          .at(0);
  // memguard's defaults: overflow sampling, a 1 ms period.
  REQUIRE(mg.regulation.sampling == Sampling::Overflow);
  REQUIRE(mg.regulation.regulation_period_us == 1000);
  const json rep = test::run_point_report(mg);
  const json base = test::run_point_report(none);

  const double budget = budget_bytes(100.0, 2000.0, kNsPerMs);
  const auto irq = samples_of(rep, "overflow_irq");
  REQUIRE_FALSE(irq.empty());
  const double max_irq_us = *std::max_element(irq.begin(), irq.end());
  // orin-agx: overflow_irq_us is normal(4, 0.5) within [3, 6] us.
  CHECK(max_irq_us <= 6.0);
  CHECK(*std::min_element(irq.begin(), irq.end()) >= 3.0);
  // The overshoot: what the core moves while the interrupt is delivered, at most at its
  // unregulated rate (+2 %: the loosely-timed memory model after a change), plus one line per
  // counted event of slack.
  const double bound = budget + unregulated_rate(mg) * max_irq_us * 1e3 * 1.02 + 2 * 64;
  int windows = 0, over_budget = 0;
  for (const auto& w : rep["windows"]) {
    if (!w["complete"].get<bool>()) continue;
    ++windows;
    const double bytes = w["bytes"];
    INFO("window " << w["index"] << " moved " << bytes << " B; budget " << budget << ", bound "
                   << bound);
    CHECK(bytes <= bound);
    over_budget += bytes > budget;
  }
  CHECK(windows >= 50);
  CHECK(over_budget > windows / 2);  // the bound is not vacuous: it is hit nearly every period
  // A throttle nearly every period, each taking hold one interrupt latency after the crossing.
  const int throttles = rep["nrt"][0]["throttle_count"];
  CHECK(throttles >= windows * 9 / 10);
  for (double d : samples_of(rep, "activation_delay")) {
    CHECK(d >= 3.0);
    CHECK(d <= 6.0);
  }
  // Held near its budget, 2000 MB/s (its unregulated rate is far above it): within the bound of
  // one period's traffic, and above the budget alone.
  const double mbps = rep["nrt"][0]["bandwidth_mbps"];
  CHECK(mbps <= bound / kBytesPerMb * 1000.0);
  CHECK(mbps > 2000.0);
  CHECK(base["nrt"][0]["bandwidth_mbps"].get<double>() > 4 * 2000.0);
  // The RT node runs faster than in the unregulated co-run.
  INFO("RT slowdown: memguard " << rt_slowdown(rep) << ", none " << rt_slowdown(base));
  CHECK(rt_slowdown(rep) < rt_slowdown(base) - 0.1);
}

TEST_CASE("memguard: separate read and write budgets throttle a writer on its write budget",
          "[sim][policies][memguard]") {
  test::TempDir dir;
  json reg = {{"policy", "memguard"},
              {"event_budget_mbps", {{"l2d_cache_refill", 20000}, {"l2d_cache_wb", 1000}}}};
  json doc = scenario(reg);
  doc["nodes"]["nrt"][0]["workload"] = "bandwidth_write";
  const auto s = test::load_points_json(doc, dir.path()).at(0);
  const json rep = test::run_point_report(s);
  // bandwidth_write moves as many write-backs as refills: held by the 1000 MB/s write budget,
  // its total traffic stays near twice that, far under the read budget.
  const double mbps = rep["nrt"][0]["bandwidth_mbps"];
  CHECK(rep["nrt"][0]["throttle_count"].get<int>() > 50);
  CHECK(mbps < 2 * 1000.0 * 1.1);
  CHECK(mbps > 2 * 1000.0 * 0.8);
}

TEST_CASE(
    "mempol: polling every 5 us through debug registers holds the nRT node to its share with "
    "at most one poll's overshoot, and protects the RT node",
    "[sim][policies][mempol]") {
  test::TempDir dir;
  const auto none = test::load_points_json(scenario({{"policy", "none"}}), dir.path()).at(0);
  const auto mp =
      test::load_points_json(scenario({{"policy", "mempol"}, {"budget_mbps", 2000}}), dir.path())
          .at(0);
  REQUIRE(mp.regulation.sampling == Sampling::Mmio);
  REQUIRE(mp.regulation.sampling_period_us == 5);
  const json rep = test::run_point_report(mp);
  const json base = test::run_point_report(none);
  const double budget = budget_bytes(100.0, 2000.0, kNsPerMs);
  // One polling period plus one poll (1.5 us at most on orin-agx) at the unregulated rate.
  const double bound = budget + unregulated_rate(mp) * (5.0 + 1.5) * 1e3 * 1.02;
  int windows = 0;
  for (const auto& w : rep["windows"]) {
    if (!w["complete"].get<bool>()) continue;
    ++windows;
    INFO("window " << w["index"] << " moved " << w["bytes"] << " B; bound " << bound);
    CHECK(w["bytes"].get<double>() <= bound);
  }
  CHECK(windows >= 50);
  CHECK(rep["nrt"][0]["throttle_count"].get<int>() >= windows * 9 / 10);
  CHECK(rep["nrt"][0]["bandwidth_mbps"].get<double>() <= 2000.0 * 1.05);
  INFO("RT slowdown: mempol " << rt_slowdown(rep) << ", none " << rt_slowdown(base));
  CHECK(rt_slowdown(rep) < rt_slowdown(base) - 0.1);
}

TEST_CASE("mempol: a global cap below the sum of the shares throttles both nRT cores together",
          "[sim][policies][mempol]") {
  test::TempDir dir;
  json doc = scenario({{"policy", "mempol"}, {"budget_mbps", 3000}, {"global_budget_mbps", 3000}});
  doc["nodes"]["nrt"].push_back({{"name", "nrt1"}, {"core", 3}, {"workload", "bandwidth_read"}});
  const auto s = test::load_points_json(doc, dir.path()).at(0);
  const json rep = test::run_point_report(s);
  // Each core's share (3000 MB/s) is never the limit: the cap over both is.
  const double both =
      rep["nrt"][0]["bandwidth_mbps"].get<double>() + rep["nrt"][1]["bandwidth_mbps"].get<double>();
  CHECK(both <= 3000.0 * 1.05);
  CHECK(both >= 3000.0 * 0.8);
  CHECK(rep["nrt"][0]["throttle_count"] == rep["nrt"][1]["throttle_count"]);
}

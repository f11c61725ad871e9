// The calibration fit (sim/calibration/fit.h): synthetic measurements generated from known
// parameters with the fit's own prediction code (the sim's profile and steady state), with
// seeded 2 % lognormal noise, are fitted back within stated tolerances; fits the data cannot
// support are refused; the fitted platform validates against the schema and runs in sim, where
// an isolation run takes the time the fit predicts.
#include <catch2/catch.hpp>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <set>

#include "calibration/fit.h"
#include "core/error.h"
#include "load/loader.h"
#include "load/schema.h"
#include "platform/sim_platform.h"
#include "sim_test_util.h"

using namespace rosguard;
using namespace rosguard::calibration;
using json = nlohmann::json;

namespace {

// A host like the 16-vCPU device VM cut to one 4-core cluster: 32 KB L1d, 512 KB L2, 32 MB L3.
HostFacts host(int cores = 4) {
  return {"synthetic",           "test CPU", cores, 1, cores, 2445.0, 64, 32, 512, 32768,
          "2026-11-23T14:00:00Z"};
}

// The "true" model the synthetic host follows.
sim::SimPlatform truth(const HostFacts& h) {
  sim::SimPlatform p = model_platform(h);
  p.l3.latency_ns = 14.0;
  p.l3.queue_ns = 6.0;
  p.l3.bandwidth_mbps = 150000.0;
  p.dram.latency_ns = 85.0;
  p.dram.queue_ns = 30.0;
  p.dram.bandwidth_mbps = 30000.0;
  p.dram.writeback_weight = 0.6;  // off its prior's median (1): the writer co-runs must show it
  p.kernels["bandwidth_read"] = {0.35, 1.0, 10.0};
  p.kernels["bandwidth_write"] = {0.5, 1.8, 6.0};
  p.kernels["latency"] = {5.0, 14.0, 1.0};
  return p;
}

// What a calibration suite measures: each kernel alone over working sets from the L1 to beyond
// the L3, the bandwidth-latency curves (each kernel against 1..N-1 bandwidth_read or
// bandwidth_write co-runners, within the L3 and beyond it), and two runs that overflow the L3
// together. ns_per_line from `p`, times exp(noise * N(0, 1)).
Measurements synthetic(const sim::SimPlatform& p, const HostFacts& h, double noise, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  Measurements m;
  m.host = h;
  const auto add = [&](const std::string& k, double ws, std::vector<KernelRun::Corunner> co) {
    KernelRun r{k, ws, std::move(co), 0.0, noise, 7};
    r.ns_per_line = predict_ns_per_line(p, r) * std::exp(noise * n01(rng));
    m.runs.push_back(r);
  };
  for (const char* k : {"bandwidth_read", "bandwidth_write", "latency"}) {
    for (double ws : {16.0, 128.0, 256.0, 2048.0, 8192.0, 65536.0, 262144.0})
      add(k, ws, {});
    for (const char* co : {"bandwidth_read", "bandwidth_write"})
      for (double ws : {2048.0, 65536.0})
        for (int n = 1; n < h.cores_per_cluster; ++n)
          add(k, ws, std::vector<KernelRun::Corunner>(static_cast<std::size_t>(n), {co, ws}));
  }
  add("bandwidth_read", 16384, {{"bandwidth_read", 24576}});
  add("latency", 8192, {{"bandwidth_read", 30720}});
  for (const char* c : {"pmc_callback", "publish", "message_latency", "controller_callback",
                        "throttle_activation", "external_read"})
    for (int i = 0; i < 200; ++i)
      m.costs_us[c].push_back(2.0 + 10.0 * std::exp(0.4 * n01(rng)));
  return m;
}

// The measurements of a calibration.json in tests/sim/fixtures/measured/.
Measurements measured(const std::string& file) {
  const auto path = test::source_dir() / "tests/sim/fixtures/measured" / file;
  return measurements_from_json(json::parse(test::read_text(path)).at("measurements"),
                                path.string());
}

const FittedParameter& param(const FitReport& r, const std::string& name) {
  for (const auto& p : r.parameters)
    if (p.name == name) return p;
  FAIL("no parameter " << name);
  throw;
}

// name -> (true value, relative tolerance). The tolerances: the worst error over seeds 1..20
// with 2 % noise, rounded up with a margin (ns_per_line_l2: 4.3 %, ns_per_line_l3: 7.3 %, mlp:
// 2.5 %, dram latency 5.3 %, L3 bandwidth 12.5 %, DRAM bandwidth 34 %, L3 queue 39 %, DRAM
// queue 84 %, write-back weight 20 %). The queues are the weakest: a 4-core cluster gives 3
// loaded levels, and the latency curve bends little before saturation. ns_per_line_l3 trades off
// against the L3 queue in isolation. The DRAM's bandwidth, queue and write-back weight share one
// ridge: the writer co-runs' DRAM traffic is reads plus weighted write-backs over the bandwidth
// (without the weight, the DRAM bandwidth's worst error was 14 %, its queue's 42 %).
std::vector<std::tuple<std::string, double, double>> targets(const sim::SimPlatform& t) {
  const auto& br = t.kernels.at("bandwidth_read");
  const auto& bw = t.kernels.at("bandwidth_write");
  const auto& lat = t.kernels.at("latency");
  return {
      {"kernels.bandwidth_read.ns_per_line_l2", br.ns_per_line_l2, 0.05},
      {"kernels.bandwidth_read.ns_per_line_l3", br.ns_per_line_l3, 0.10},
      {"kernels.bandwidth_read.mlp", br.mlp, 0.05},
      {"kernels.bandwidth_write.ns_per_line_l2", bw.ns_per_line_l2, 0.05},
      {"kernels.bandwidth_write.ns_per_line_l3", bw.ns_per_line_l3, 0.10},
      {"kernels.bandwidth_write.mlp", bw.mlp, 0.05},
      {"kernels.latency.ns_per_line_l2", lat.ns_per_line_l2, 0.05},
      {"kernels.latency.ns_per_line_l3", lat.ns_per_line_l3, 0.05},
      {"l3.queue_ns", t.l3.queue_ns, 0.5},
      {"l3.bandwidth_mbps", t.l3.bandwidth_mbps, 0.2},
      {"dram.latency_ns", t.dram.latency_ns, 0.06},
      {"dram.queue_ns", t.dram.queue_ns, 1.0},
      {"dram.bandwidth_mbps", t.dram.bandwidth_mbps, 0.4},
      {"dram.writeback_weight", t.dram.writeback_weight, 0.25},
  };
}

}  // namespace

TEST_CASE("fit: noise-free synthetic measurements give back the true parameters", "[sim][fit]") {
  const HostFacts h = host();
  const sim::SimPlatform t = truth(h);
  const FitReport r = fit(synthetic(t, h, 0.0, 1));
  CHECK(r.converged);
  // The priors pull each value towards their medians as one measurement with the runs' noise
  // floor (2 %) would: a small bias, well within a quarter of each parameter's tolerance at 2 %
  // noise, and no parameter prior-dominated.
  CHECK(r.rms_residual < 0.005);
  for (const auto& [name, value, tol] : targets(t)) {
    INFO(name);
    CHECK(param(r, name).value == Approx(value).epsilon(tol / 4));
    CHECK(param(r, name).fitted);
    CHECK_FALSE(param(r, name).prior_dominated);
  }
  CHECK_FALSE(param(r, "kernels.latency.mlp").fitted);
  CHECK(param(r, "l3.latency_ns").value == param(r, "kernels.latency.ns_per_line_l3").value);
  // The runs within the L1d are reported, not fitted.
  std::size_t unused = 0;
  for (const auto& run : r.runs)
    unused += run.used ? 0 : 1;
  CHECK(unused == 3);
}

TEST_CASE("fit: 2 % noise, parameters recovered within the stated tolerances", "[sim][fit]") {
  const HostFacts h = host();
  const sim::SimPlatform t = truth(h);
  for (unsigned seed : {1u, 2u, 3u}) {
    const FitReport r = fit(synthetic(t, h, 0.02, seed));

    INFO("seed " << seed << ": " << to_json(r).dump(1));
    CHECK(r.converged);
    // The residuals are the noise: RMS near 0.02 (log units).
    CHECK(r.rms_residual > 0.012);
    CHECK(r.rms_residual < 0.025);
    for (const auto& [name, value, tol] : targets(t)) {
      const FittedParameter& p = param(r, name);
      INFO(name << ": fitted " << p.value << " +- " << p.std_error << ", true " << value);
      CHECK(p.value == Approx(value).epsilon(tol));
      // The standard error is honest: the truth lies within 4 of them.
      CHECK(std::abs(p.value - value) < 4.0 * p.std_error);
    }
  }
}

TEST_CASE("fit: a 2-core host (one co-runner): the queues' priors decide the ridge", "[sim][fit]") {
  const HostFacts h = host(2);
  const sim::SimPlatform t = truth(h);
  const FitReport r = fit(synthetic(t, h, 0.02, 7));
  INFO(to_json(r).dump(1));
  CHECK(r.converged);
  // One co-runner count: a queue trades off against its bandwidth along a ridge, and its prior
  // (the unloaded latency) says where on it the fit sits; whatever the runs leave to the prior
  // is flagged.
  for (const char* name :
       {"l3.queue_ns", "dram.queue_ns", "l3.bandwidth_mbps", "dram.bandwidth_mbps"}) {
    const FittedParameter& p = param(r, name);
    CHECK(p.fitted);
    CHECK(p.prior_dominated == (p.data_share < 0.5));
    CHECK(std::abs(std::log(p.value / p.prior_median)) < 3.0 * p.prior_log_sd);
  }
  // What a single co-runner identifies is still recovered, and every run is predicted within
  // the noise.
  CHECK(param(r, "dram.latency_ns").value == Approx(t.dram.latency_ns).epsilon(0.05));
  CHECK(param(r, "kernels.bandwidth_read.mlp").value ==
        Approx(t.kernels.at("bandwidth_read").mlp).epsilon(0.1));
  CHECK(r.rms_residual < 0.025);
  for (const auto& run : r.runs)
    if (run.used) CHECK(std::abs(run.residual) < 0.07);
}

TEST_CASE("fit: the co-runners' placement the runs show (one L3 shared, or each its own) is kept",
          "[sim][fit]") {
  // A 2-core host whose probe says both cores share the L3; measured once with the host running
  // them on one L3, once on two (a VM's vCPUs, as the AMD EPYC VM of 2026-11-28 showed).
  const HostFacts h = host(2);
  const sim::SimPlatform shared = truth(h);
  sim::SimPlatform apart = shared;
  apart.clusters = 2;
  apart.cores_per_cluster = 1;
  // What tells them apart: a set within the L3 beside a stream beyond it is evicted to DRAM by a
  // shared L3 only (and co-runs within the L3 queue at a shared L3 only).
  const KernelRun chase{"latency", 16384.0, {{"bandwidth_read", 65536.0}}, 0.0, 0.0, 0};
  REQUIRE(predict_ns_per_line(shared, chase) > 3.0 * predict_ns_per_line(apart, chase));

  // The suite measures such runs (a chase within the L3 beside a reader or writer beyond it).
  const auto with_chases = [&](const sim::SimPlatform& p) {
    Measurements m = synthetic(p, h, 0.02, 3);
    for (const char* co : {"bandwidth_read", "bandwidth_write"}) {
      KernelRun r{"latency", 16384.0, {{co, 65536.0}}, 0.0, 0.02, 7};
      r.ns_per_line = predict_ns_per_line(p, r);
      m.runs.push_back(r);
    }
    return m;
  };
  const Measurements on_one_runs = with_chases(shared);
  const FitReport on_one = fit(on_one_runs);
  INFO(to_json(on_one).dump(1));
  CHECK(on_one.placement == "probed");
  CHECK(on_one.platform.cores_per_cluster == 2);
  CHECK(on_one.rms_probed < 0.03);
  CHECK(on_one.rms_apart > 2.0 * on_one.rms_probed);
  CHECK(on_one.notes.front().starts_with("placement: the co-runners in the probed clusters"));

  const Measurements on_two_runs = with_chases(apart);
  const FitReport on_two = fit(on_two_runs);
  INFO(to_json(on_two).dump(1));
  CHECK(on_two.placement == "apart");
  CHECK(on_two.platform.clusters == 2);
  CHECK(on_two.platform.cores_per_cluster == 1);
  CHECK(on_two.rms_apart < 0.03);
  CHECK(on_two.rms_probed > 2.0 * on_two.rms_apart);
  CHECK(on_two.notes.front().starts_with("placement: the co-runners each in a cluster of its own"));
  CHECK(predict_ns_per_line(on_two.platform, chase) ==
        Approx(predict_ns_per_line(apart, chase)).epsilon(0.1));
  // The written model says so, and has those clusters.
  const json doc = fitted_platform(on_two_runs, on_two, "apart-host");
  CHECK(doc["cpu"]["clusters"] == 2);
  CHECK(doc["cpu"]["cores_per_cluster"] == 1);
  CHECK(doc["cpu"]["source"].get<std::string>().find("clusters of one core") != std::string::npos);
  CHECK(to_json(on_two)["placement"]["chosen"] == "apart");

  // A placement asked for is kept, even where the runs disagree.
  FitOptions asked;
  asked.placement = Placement::Apart;
  const FitReport forced = fit(on_one_runs, asked);
  CHECK(forced.placement == "apart");
  CHECK(forced.platform.cores_per_cluster == 1);
  CHECK(forced.rms_residual == Approx(on_one.rms_apart));
  CHECK(std::isnan(forced.rms_probed));
  CHECK(to_json(forced)["placement"].dump().find("\"rms_probed\":null") != std::string::npos);
  CHECK(forced.notes.front().starts_with("placement: each core in a cluster of its own"));
}

TEST_CASE("fit: insufficient data is refused, naming what is missing", "[sim][fit]") {
  const HostFacts h = host();
  Measurements m = synthetic(truth(h), h, 0.02, 1);
  SECTION("no latency kernel") {
    std::erase_if(m.runs, [](const KernelRun& r) { return r.kernel == "latency"; });
    CHECK_THROWS_WITH(fit(m), Catch::Contains("insufficient measurements") &&
                                  Catch::Contains("isolation runs of latency"));
  }
  SECTION("no isolation run of bandwidth_write within the L3") {
    std::erase_if(m.runs, [&](const KernelRun& r) {
      return r.kernel == "bandwidth_write" && r.corunners.empty() && r.working_set_kb > h.l2_kb &&
             r.working_set_kb <= h.l3_kb_per_cluster;
    });
    CHECK_THROWS_WITH(fit(m), Catch::Contains("an isolation run of bandwidth_write within the L3"));
  }
}

TEST_CASE("fit: what the runs cannot show rests on its prior, named as prior-dominated",
          "[sim][fit]") {
  const HostFacts h = host();
  const sim::SimPlatform t = truth(h);
  Measurements m = synthetic(t, h, 0.02, 1);
  const auto dominated = [](const FitReport& r, const std::string& name) {
    return param(r, name).prior_dominated;
  };
  SECTION("no co-run beyond the L3: the DRAM queue and bandwidth") {
    // Isolation runs beyond the L3 stay; every run with a co-runner beyond it, or whose sets
    // overflow the L3 together, goes.
    std::erase_if(m.runs, [&](const KernelRun& r) {
      double total = r.working_set_kb;
      for (const auto& c : r.corunners)
        total += c.working_set_kb;
      return !r.corunners.empty() && total > h.l3_kb_per_cluster;
    });
    const FitReport r = fit(m);
    INFO(to_json(r).dump(1));
    CHECK(r.converged);
    // A single stream beyond the L3 loads DRAM too, so the isolation runs still say something of
    // the bandwidth; the queue needs co-runs.
    CHECK(dominated(r, "dram.queue_ns"));
    CHECK_FALSE(dominated(r, "dram.latency_ns"));
    CHECK_FALSE(dominated(r, "l3.bandwidth_mbps"));
    CHECK(param(r, "dram.latency_ns").value == Approx(t.dram.latency_ns).epsilon(0.06));
    // A write-back's weight shows only where a writer meets another stream in DRAM: held at 1,
    // saying why, and written so.
    CHECK_FALSE(param(r, "dram.writeback_weight").fitted);
    CHECK(param(r, "dram.writeback_weight").value == 1.0);
    CHECK_THAT(param(r, "dram.writeback_weight").how,
               Catch::Contains("no co-run beyond the L3 with a writing kernel"));
    CHECK(r.platform.dram.writeback_weight == 1.0);
    bool noted = false;
    for (const auto& note : r.notes)
      noted = noted || note.find("no co-run beyond the L3") != std::string::npos;
    CHECK(noted);
    FitOptions strict;
    strict.strict = true;
    CHECK_THROWS_WITH(fit(m, strict), Catch::Contains("the data cannot identify dram.") &&
                                          Catch::Contains("--strict"));
  }
  SECTION("no run beyond the L3 at all (an LLC larger than the suite's largest set)") {
    std::erase_if(m.runs, [&](const KernelRun& r) {
      double total = r.working_set_kb;
      for (const auto& c : r.corunners)
        total += c.working_set_kb;
      return total > h.l3_kb_per_cluster;
    });
    const FitReport r = fit(m);
    INFO(to_json(r).dump(1));
    CHECK(r.converged);
    for (const char* name : {"dram.latency_ns", "dram.queue_ns", "dram.bandwidth_mbps"})
      CHECK(dominated(r, name));
    // The typical values stand in: the DRAM latency near 90 ns less the L3's.
    CHECK(param(r, "dram.latency_ns").prior_median ==
          Approx(90.0 - param(r, "l3.latency_ns").value).epsilon(0.02));
    // What the runs show is still theirs (a kernel's misses in flight also shape its co-runs
    // within the L3, so its mlp is seen there, trading a little against its L3 time).
    for (const char* name : {"kernels.bandwidth_read.ns_per_line_l3", "kernels.bandwidth_read.mlp",
                             "l3.bandwidth_mbps"})
      CHECK_FALSE(dominated(r, name));
    CHECK(param(r, "kernels.bandwidth_read.ns_per_line_l3").value ==
          Approx(t.kernels.at("bandwidth_read").ns_per_line_l3).epsilon(0.1));
  }
  SECTION("fewer runs than parameters") {
    // Each kernel alone in the L2, the L3 and beyond; one co-run at each level: 11 runs for 13
    // parameters.
    Measurements few = m;
    few.runs.clear();
    for (const auto& r : m.runs) {
      const bool iso =
          r.corunners.empty() &&
          (r.working_set_kb == 128 || r.working_set_kb == 2048 || r.working_set_kb == 65536);
      const bool co = r.kernel == "bandwidth_read" && r.corunners.size() == 1 &&
                      r.corunners[0].kernel == "bandwidth_read" &&
                      r.corunners[0].working_set_kb == r.working_set_kb;
      if (iso || co) few.runs.push_back(r);
    }
    REQUIRE(few.runs.size() == 11);
    const FitReport r = fit(few);
    INFO(to_json(r).dump(1));
    CHECK(r.converged);
    CHECK(r.rms_residual < 0.05);
  }
}

TEST_CASE("fit: data the model cannot follow is refused or left to the priors", "[sim][fit]") {
  const HostFacts h = host();
  Measurements m = synthetic(truth(h), h, 0.02, 1);
  // The probed clusters only: these are the solver's refusals, not the placement's choice (the
  // second fit, each core its own L3, took 4x the first's time on the refused data: 138 s).
  FitOptions o;
  o.placement = Placement::AsProbed;
  SECTION("co-runs within the L3 faster than alone: the contention terms collapse") {
    std::set<std::size_t> faster;
    for (std::size_t i = 0; i < m.runs.size(); ++i) {
      KernelRun& r = m.runs[i];
      if (!r.corunners.empty() && r.working_set_kb <= h.l3_kb_per_cluster &&
          r.working_set_kb > h.l2_kb)
        for (const auto& iso : m.runs)
          if (iso.corunners.empty() && iso.kernel == r.kernel &&
              iso.working_set_kb == r.working_set_kb) {
            r.ns_per_line = iso.ns_per_line * 0.9;
            faster.insert(i);
          }
    }
    REQUIRE_FALSE(faster.empty());
    // No contention can make a co-run faster than alone: the fit drives the L3 queue towards 0
    // and the bandwidth up until their priors hold them, and predicts those runs slower than
    // measured. The runs say little about the two there: prior-dominated.
    const FitReport r = fit(m, o);
    INFO(to_json(r).dump(1));
    CHECK(r.converged);
    CHECK(
        (param(r, "l3.queue_ns").prior_dominated || param(r, "l3.bandwidth_mbps").prior_dominated));
    for (const auto& run : r.runs)
      if (faster.count(run.index)) CHECK(run.residual > 0);
    FitOptions strict = o;
    strict.strict = true;
    CHECK_THROWS_WITH(fit(m, strict), Catch::Contains("calibration: the data cannot identify l3."));
  }
  SECTION("too few evaluations to converge") {
    o.max_evaluations = 3;
    CHECK_THROWS_WITH(fit(m, o),
                      Catch::Contains("did not converge") && Catch::Contains("status 5"));
  }
  SECTION("every other run three times slower: no model state explains it") {
    for (std::size_t i = 0; i < m.runs.size(); i += 2)
      m.runs[i].ns_per_line *= 3.0;
    CHECK_THROWS_WITH(fit(m, o), Catch::Contains("calibration:") &&
                                     Catch::Contains("Levenberg-Marquardt status"));
  }
  SECTION("a residual beyond the limit") {
    o.max_rms_residual = 0.01;  // below the 2 % noise
    CHECK_THROWS_WITH(fit(m, o), Catch::Contains("cannot reproduce these measurements: RMS "
                                                 "residual 0.017 (log units) above the limit "
                                                 "0.010 (Levenberg-Marquardt status 1"));
  }
}

TEST_CASE("fit: a fixed parameter is held and reported as fixed", "[sim][fit]") {
  const HostFacts h = host();
  const sim::SimPlatform t = truth(h);
  FitOptions o;
  o.fixed["l3.queue_ns"] = 6.0;
  const FitReport r = fit(synthetic(t, h, 0.02, 1), o);
  CHECK_FALSE(param(r, "l3.queue_ns").fitted);
  CHECK(param(r, "l3.queue_ns").value == 6.0);
  CHECK(r.platform.l3.queue_ns == 6.0);
  CHECK(param(r, "l3.bandwidth_mbps").value == Approx(t.l3.bandwidth_mbps).epsilon(0.1));
}

TEST_CASE("fit: costs become distributions of the platform format", "[sim][fit]") {
  SECTION("lognormal from the median and the 90th percentile") {
    std::mt19937_64 rng(3);
    std::normal_distribution<double> n01;
    std::vector<double> s;
    for (int i = 0; i < 4000; ++i)
      s.push_back(5.0 + 10.0 * std::exp(0.5 * n01(rng)));
    const CostFit c = fit_cost(s);
    CHECK(c.distribution["dist"] == "lognormal");
    CHECK(c.distribution["median_us"].get<double>() == Approx(15.0).epsilon(0.03));
    CHECK(c.distribution["sigma"].get<double>() == Approx(0.5).margin(0.05));
    CHECK(c.distribution["min_us"].get<double>() == Approx(5.0).margin(0.7));  // the location
    CHECK(c.distribution["min_us"].get<double>() <= c.min_us);
    CHECK(c.distribution["max_us"].get<double>() == Approx(c.max_us).epsilon(1e-3));
  }
  SECTION("all equal: constant") {
    CHECK(fit_cost({2.0, 2.0, 2.0}).distribution == json{{"dist", "constant"}, {"value_us", 2.0}});
  }
  SECTION("most samples at the minimum: normal, by the percentiles") {
    const CostFit c = fit_cost({1, 1, 1, 1, 1, 1, 2, 3});
    CHECK(c.distribution["dist"] == "normal");
    CHECK(c.distribution["mean_us"].get<double>() == 1.0);  // the median
    CHECK(c.distribution["sd_us"].get<double>() == Approx((c.p90_us - 1.0) / 2.563).epsilon(0.01));
    CHECK(c.distribution["max_us"].get<double>() == 3.0);
  }
  SECTION("a far outlier widens neither the normal's centre nor its spread") {
    // The timer wake-ups of a quick suite on the development VM (2026-11-28): 15-25 us, more of
    // them near 25 (not right-skewed), and one that RT throttling held for 50 ms.
    std::vector<double> s;
    for (int i = 0; i < 499; ++i)
      s.push_back(15.0 + 10.0 * std::sqrt((i + 0.5) / 499.0));
    s.push_back(50006.651);
    const CostFit c = fit_cost(s);
    REQUIRE(c.distribution["dist"] == "normal");
    // Percentiles of 15 + 10 sqrt(u): 10th 18.16, 50th 22.07, 90th 24.49.
    CHECK(c.distribution["mean_us"].get<double>() == Approx(22.07).margin(0.05));
    CHECK(c.distribution["sd_us"].get<double>() == Approx(6.33 / 2.563).epsilon(0.02));
    CHECK(c.distribution["max_us"].get<double>() == 50006.651);  // the range is kept
  }
  SECTION("no samples") {
    CHECK_THROWS_AS(fit_cost({}), RunError);
  }
}

TEST_CASE("fit: the fitted platform validates, and sim runs it as the fit predicts", "[sim][fit]") {
  const HostFacts h = host();
  const sim::SimPlatform t = truth(h);
  const Measurements m = synthetic(t, h, 0.02, 1);
  const FitReport r = fit(m);
  const json doc = fitted_platform(m, r, "fitted-host");
  const SchemaSet schemas(Home::locate().schemas());
  CHECK_FALSE(schemas.first_error(doc, SchemaKind::Platform).has_value());
  CHECK(doc["memory"]["dram"]["source"].get<std::string>().find(
            "fitted by rosguard calibrate on synthetic at 2026-11-23T14:00:00Z") !=
        std::string::npos);
  // Reference: the measured 2048 KB bandwidth_read isolation, Eq. 1 in MiB/s.
  for (const auto& run : m.runs)
    if (run.kernel == "bandwidth_read" && run.working_set_kb == 2048 && run.corunners.empty())
      CHECK(doc["reference"]["mbps"].get<double>() ==
            Approx(64.0 * 1e9 / run.ns_per_line / 1048576.0).epsilon(1e-5));

  // Parsed back, the sim sees the fitted model (5 significant digits).
  const sim::SimPlatform back = sim::parse_sim_platform(build_platform(doc, "fitted.json"));
  CHECK(back.dram.bandwidth_mbps == Approx(r.platform.dram.bandwidth_mbps).epsilon(1e-4));
  CHECK(back.dram.writeback_weight == Approx(r.platform.dram.writeback_weight).epsilon(1e-4));
  CHECK(back.dram.writeback_weight != 1.0);
  CHECK(back.kernels.at("bandwidth_read").mlp ==
        Approx(r.platform.kernels.at("bandwidth_read").mlp).epsilon(1e-4));

  // Runs in sim: bandwidth_read (its hw section: 2048 KB, 1314 passes) alone takes what the fit
  // predicts for one line, times the lines; so does an inline kernel beyond the L3.
  test::TempDir dir;
  std::ofstream(dir.path() / "fitted.json") << doc.dump(2);
  const json scenario = {
      {"name", "fitted-run"},
      {"platform", "fitted.json"},
      {"nodes",
       {{"controller", {{"core", 0}}},
        {"rt",
         {{{"name", "rt0"}, {"core", 1}, {"workload", "bandwidth_read"}},
          {{"name", "rt1"},
           {"core", 2},
           {"workload",
            {{"name", "stream64m"},
             {"hw",
              {{"kernel", "bandwidth_write"}, {"working_set_kb", 65536}, {"passes", 2}}}}}}}}}}};
  const auto points = test::load_points_json(scenario, dir.path());
  const auto check = [&](std::size_t node, const std::string& kernel, double ws_kb, double passes) {
    const auto& rt = points.at(0).nodes.rt.at(node);
    const IsolationResult iso = test::isolation(points[0], rt.workload, rt.core);
    const double ns = predict_ns_per_line(back, {kernel, ws_kb, {}, 0.0, 0.0, 0});
    const double lines = ws_kb * 1024.0 / 64.0 * passes;
    INFO(kernel << " " << ws_kb << " KB: sim " << iso.time_us << " us, predicted "
                << ns * lines / 1e3 << " us");
    CHECK(iso.time_us == Approx(ns * lines / 1e3).epsilon(1e-4));
    // Eq. 1 of the isolation run: the L3 lines it moved (write: refills and write-backs).
    CHECK(iso.mbps ==
          Approx((kernel == "bandwidth_write" ? 2.0 : 1.0) * 64.0 * 1e9 / ns / 1048576.0)
              .epsilon(0.005));
  };
  check(0, "bandwidth_read", 2048, 1314);
  check(1, "bandwidth_write", 65536, 2);
}

// Real measurements that the fit of main 7b6769e refused (tests/sim/fixtures/measured/, copied
// from shared/measured/ with their source): three quick suites and a full one on the 2-vCPU
// development VM of 2026-11-26 (an Intel Xeon, L3 35.8 MB: rank-deficient DRAM bandwidth, an L3
// bandwidth left free), and a quick suite on a 16-vCPU Xeon with a 300 MB L3 that measured no run
// beyond it. Each now fits: what the runs do not show rests on its prior, named as
// prior-dominated; the platform validates; --strict refuses exactly those fits.
TEST_CASE("fit: the measured suites of two real hosts fit, prior-dominated parameters named",
          "[sim][fit][measured]") {
  const SchemaSet schemas(Home::locate().schemas());
  for (const char* file :
       {"devvm-xeon-2026-11-26-quick-1.json", "devvm-xeon-2026-11-26-quick-2.json",
        "devvm-xeon-2026-11-26-quick-3.json", "devvm-xeon-2026-11-26-full-1.json",
        "xeon16-2026-11-26-quick.json"}) {
    const Measurements m = measured(file);
    const FitReport r = fit(m);
    INFO(file << ": " << to_json(r).dump(1));
    CHECK(r.converged);
    CHECK(r.rms_residual < FitOptions{}.max_rms_residual);
    std::vector<std::string> dominated;
    for (const auto& p : r.parameters) {
      if (!p.fitted) continue;
      CHECK(std::isfinite(p.value));
      CHECK(p.value > 0);
      CHECK(p.log_std_error > 0);
      // The posterior is never wider than the prior.
      CHECK(p.log_std_error <= p.prior_log_sd * (1 + 1e-9));
      CHECK_FALSE(p.prior_source.empty());
      if (p.prior_dominated) dominated.push_back(p.name);
    }
    for (const auto& name : dominated) {
      bool noted = false;
      for (const auto& note : r.notes)
        noted = noted || note.rfind(name + " is prior-dominated", 0) == 0;
      CHECK(noted);
    }
    if (std::string(file).starts_with("xeon16")) {
      // No run beyond its 300 MB L3 alone: the gap is named (the DRAM side is seen only where
      // 262 MB sets overflow the L3 together).
      bool noted = false;
      for (const auto& note : r.notes)
        noted = noted || note.starts_with("no isolation run of latency beyond the L3");
      CHECK(noted);
    }
    const json platform = fitted_platform(m, r, "replayed");
    CHECK_FALSE(schemas.first_error(platform, SchemaKind::Platform).has_value());
    // The band: each prior-dominated parameter one standard error down and up, nothing else.
    const auto band = band_platforms(platform, r);
    REQUIRE(band.size() == 2 * dominated.size());
    for (std::size_t i = 0; i < band.size(); ++i) {
      const auto& [variant, variant_doc] = band[i];
      const FittedParameter& p = param(r, dominated[i / 2]);
      CHECK(variant == "replayed-" + p.name + (i % 2 ? "-high" : "-low"));
      CHECK_FALSE(schemas.first_error(variant_doc, SchemaKind::Platform).has_value());
      const json diff = json::diff(platform, variant_doc);
      std::set<std::string> changed;
      for (const auto& op : diff) {
        const std::string where = op["path"];
        if (where != "/name" && where != "/description" && !where.ends_with("/source"))
          changed.insert(where);
      }
      REQUIRE(changed.size() == 1);
      const double moved = variant_doc[json::json_pointer(*changed.begin())].get<double>();
      CHECK(moved == Approx(p.value * std::exp((i % 2 ? 1 : -1) * p.log_std_error)).epsilon(1e-4));
    }
    // Strict, in the placement the fit kept (refitting both would double this test's time).
    CHECK(r.placement == "probed");
    FitOptions strict;
    strict.strict = true;
    strict.placement = Placement::AsProbed;
    if (dominated.empty())
      CHECK_NOTHROW(fit(m, strict));
    else
      CHECK_THROWS_AS(fit(m, strict), UnidentifiedParameter);
  }
}

// A quick suite of the 2-vCPU development VM of 2026-11-28 (Intel Xeon, L3 105 MB; the 9th of 10
// `calibrate --quick --install` runs, copied from its calibration.json): its co-runs beyond the L3
// show no DRAM contention between the vCPUs, and its writers' co-runs slow the reader through
// something else; the fit put dram.writeback_weight at 4.92, beyond the platform schema's range
// (0, 4], and calibrate wrote nothing ("/memory/dram/writeback_weight: must be in (0, 4]"). It is
// now held at 4, named, and the rest fitted again: the model validates; --strict refuses it.
TEST_CASE("fit: a parameter the runs push beyond its range is held at its end, named",
          "[sim][fit][measured]") {
  const Measurements m = measured("devvm-xeon-2026-11-28-quick.json");
  FitOptions o;
  o.placement = Placement::AsProbed;  // the placement calibrate kept (the other: 9.1 %, 8.0 here)
  const FitReport r = fit(m, o);
  INFO(to_json(r).dump(1));
  CHECK(r.converged);
  const FittedParameter& w = param(r, "dram.writeback_weight");
  CHECK(w.value == 4.0);
  CHECK(w.at_bound);
  CHECK_FALSE(w.fitted);
  CHECK_THAT(w.how, Catch::Contains("the end of its range") && Catch::Contains("fitted freely"));
  CHECK(r.platform.dram.writeback_weight == 4.0);
  bool noted = false;
  for (const auto& note : r.notes)
    noted = noted || note.starts_with("dram.writeback_weight held at 4");
  CHECK(noted);
  for (const auto& p : r.parameters)
    if (p.name != w.name) CHECK_FALSE(p.at_bound);
  const SchemaSet schemas(Home::locate().schemas());
  const json platform = fitted_platform(m, r, "replayed");
  CHECK_FALSE(schemas.first_error(platform, SchemaKind::Platform).has_value());
  for (const auto& [variant, doc] : band_platforms(platform, r))
    CHECK_FALSE(schemas.first_error(doc, SchemaKind::Platform).has_value());
  FitOptions strict = o;
  strict.strict = true;
  CHECK_THROWS_WITH(fit(m, strict), Catch::Contains("dram.writeback_weight held at 4"));
}

// A quick suite of the 2-vCPU development VM of 2026-11-27 (AMD EPYC, L3 32 MB; `make validate`'s
// calibration, copied from its results/calibration/calibration.json): there a writer beyond the
// L3 slows a reader no more than another reader does. With a write-back held at one line of DRAM
// traffic, no one DRAM bandwidth fits both co-runs, and the reader-reader one is predicted 16 %
// fast; fitted, the weight closes that gap.
TEST_CASE("fit: the write-back weight the EPYC VM's writer co-runs show is fitted",
          "[sim][fit][measured]") {
  const Measurements m = measured("devvm-epyc-2026-11-27-quick.json");
  const auto reader_pair = [](const FitReport& r) {
    for (const auto& run : r.runs)
      if (run.label == "bandwidth_read 131072 KB + bandwidth_read 131072 KB") return run.residual;
    FAIL("no reader-reader co-run beyond the L3");
    return 0.0;
  };
  const FitReport r = fit(m);
  INFO(to_json(r).dump(1));
  const FittedParameter& w = param(r, "dram.writeback_weight");
  CHECK(w.fitted);
  CHECK_FALSE(w.prior_dominated);
  CHECK(std::abs(reader_pair(r)) < 0.08);
  FitOptions held;
  held.fixed["dram.writeback_weight"] = 1.0;
  const FitReport one = fit(m, held);
  CHECK(reader_pair(one) < -0.15);
  CHECK(r.rms_residual < one.rms_residual);
}

// A second quick suite of the same VM, 2026-11-27 22:25 (`make validate`'s calibration with no
// model installed). From the priors' medians alone, LM stopped in a local minimum along the DRAM's
// queue-bandwidth ridge: a 252 GB/s DRAM with a 179 ns queue, RMS residual 7.7 %, every co-run
// beyond the L3 predicted 10-23 % fast. The fit also starts from lower bandwidths and keeps the
// lowest objective.
TEST_CASE("fit: a local minimum along the DRAM's queue-bandwidth ridge is left for a better one",
          "[sim][fit][measured]") {
  const Measurements m = measured("devvm-epyc-2026-11-27-quick-2.json");
  const FitReport r = fit(m);
  INFO(to_json(r).dump(1));
  CHECK(r.converged);
  CHECK(r.rms_residual < 0.06);
  // The runs' largest DRAM traffic (two streams, 2 x 64 B / 3.5 ns, about 35 GB/s) is near what
  // the DRAM gives; a bandwidth several times that would leave the co-runs unexplained.
  CHECK(r.platform.dram.bandwidth_mbps < 100000.0);
  for (const auto& run : r.runs)
    if (run.label == "bandwidth_read 131072 KB + bandwidth_read 131072 KB")
      CHECK(std::abs(run.residual) < 0.15);
}

// The quick suite `make validate` ran with no model installed on the AMD EPYC VM, 2026-11-28
// 09:26. The pointer chase between the L2 and the L3 keeps a share of its loads in the L2 (uniform
// reuse: 1/2 at 2 MB, 1/4 at 4 MB); with every one an L2 refill (the streams' rule) it was
// predicted 30 % slow alone at 2 MB and 23 % slow at 4 MB beside a DRAM stream, the DRAM queue
// bent to that, and two DRAM readers side by side came out 17 % fast (RMS residual 9.7 %).
TEST_CASE("fit: the pointer chase's L2 hits (uniform reuse) leave the DRAM co-runs to the DRAM",
          "[sim][fit][measured]") {
  const Measurements m = measured("devvm-epyc-2026-11-28-quick.json");
  const FitReport r = fit(m);
  INFO(to_json(r).dump(1));
  CHECK(r.converged);
  CHECK(r.rms_residual < 0.04);
  const auto residual = [&](const std::string& label) {
    for (const auto& run : r.runs)
      if (run.label == label) return run.residual;
    FAIL("no run " << label);
    return 0.0;
  };
  CHECK(std::abs(residual("latency 2048 KB")) < 0.1);
  CHECK(std::abs(residual("latency 4096 KB + bandwidth_read 131072 KB")) < 0.1);
  CHECK(std::abs(residual("bandwidth_read 131072 KB + bandwidth_read 131072 KB")) < 0.1);
  for (const char* name : {"dram.queue_ns", "dram.bandwidth_mbps", "dram.writeback_weight"})
    CHECK_FALSE(param(r, name).prior_dominated);
}

// A co-run block the suite kept in another DRAM-interference state than most of its probes (the
// host moved the vCPUs for longer than the suite waits): its runs are left out of the fit, each
// with a note naming the state. On the VM at 10:39 (2026-11-28) the writer block met 1.0x in a
// suite at 1.75x; fitted with the rest, its near-free writer pairs pulled the reader pair's
// prediction to 3.05 ns per line against 4.67 measured.
TEST_CASE("fit: co-runs measured in another DRAM-interference state are left out, named",
          "[sim][fit][measured]") {
  Measurements m = measured("devvm-epyc-2026-11-28-quick.json");
  m.contention.clear();
  calibration::ContentionProbe p;
  p.cores = {0, 1};
  p.working_set_kb = 131072;
  p.rounds = 7;
  for (const double ratio : {1.5, 1.52, 1.0}) {
    p.ratio = ratio;
    p.when = "probe " + std::to_string(m.contention.size());
    m.contention.push_back(p);
  }
  // The first two blocks between probes 0 and 1, the writers' beside the 1.0x one.
  std::size_t out = 0, in = 0;
  for (auto& r : m.runs) {
    if (r.corunners.empty()) continue;
    const bool writer = r.corunners[0].kernel == "bandwidth_write";
    r.probes = writer ? std::vector<int>{1, 2} : std::vector<int>{0, 1};
    (writer ? out : in) += 1;
  }
  REQUIRE(out > 0);
  const FitReport r = fit(m);
  std::size_t left_out = 0;
  for (const auto& run : r.runs) {
    const bool writer = run.label.find("+ bandwidth_write") != std::string::npos;
    CHECK(run.used != writer);
    if (writer) {
      ++left_out;
      CHECK_THAT(run.note, Catch::StartsWith("left out: measured in another DRAM-interference "
                                             "state than the suite's (1.51x"));
      CHECK_THAT(run.note, Catch::Contains("probe 1.00x probe 2"));
    }
  }
  CHECK(left_out == out);
  // With every probe in one state nothing is left out.
  m.contention[2].ratio = 1.49;
  for (const auto& run : fit(m).runs)
    CHECK(run.used);
}

TEST_CASE("fit: the preemption pairs become a constant cost at their median", "[sim][fit]") {
  const CostFit c = fit_mean_cost({14.5, -3.0, 30.0, 12.0, 16.0});
  CHECK(c.samples == 5);
  CHECK(c.distribution == json{{"dist", "constant"}, {"value_us", 14.5}});
  // Noise may put the median below 0: no cost, not a negative one.
  CHECK(fit_mean_cost({-2.0, -1.0, 3.0}).distribution["value_us"].get<double>() == 0.0);
  CHECK_THROWS_AS(fit_mean_cost({}), RunError);

  // In the platform: preemption_us, constant, its source saying what the samples are.
  const HostFacts h = host();
  Measurements m = synthetic(truth(h), h, 0.02, 1);
  m.costs_us["preemption"] = {13.0, 14.0, 15.0, 9.0};
  const FitReport r = fit(m);
  const json doc = fitted_platform(m, r, "fitted-host");
  const SchemaSet schemas(Home::locate().schemas());
  CHECK_FALSE(schemas.first_error(doc, SchemaKind::Platform).has_value());
  const json& p = doc["costs"]["preemption_us"];
  CHECK(p["dist"] == "constant");
  CHECK(p["value_us"].get<double>() == Approx(13.5));
  CHECK(p["source"].get<std::string>().find("the median of 4 pairs of timed windows") !=
        std::string::npos);
  CHECK(p["source"].get<std::string>().find("): 13.5 us;") != std::string::npos);
  // A median below 0, held at 0, says so.
  m.costs_us["preemption"] = {-2.0, -1.0, 3.0};
  const json held = fitted_platform(m, fit(m), "fitted-host")["costs"]["preemption_us"];
  CHECK(held["value_us"].get<double>() == 0.0);
  CHECK(held["source"].get<std::string>().find("-1 us, held at 0") != std::string::npos);
  CHECK(sim::parse_sim_platform(build_platform(doc, "fitted.json")).costs.preemption.has_value());
}

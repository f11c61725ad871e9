// Fidelity: the paper's findings (paper/summary.md, experiments 1-8), each stated as the paper
// states it, on the paper-reproduction scenarios in scenarios/paper/ run through the CLI.
// Numbers the paper gives are checked with a tolerance; trends are checked as trends, with a
// small allowance where the paper itself reports saturation (plateaus that seeds jitter).
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <fstream>
#include <map>
#include <numeric>
#include <set>

#include "metric/metric.h"
#include "sim_test_util.h"

using namespace rosguard;
using Row = std::map<std::string, std::string>;

namespace {

std::vector<Row> run_scenario(const std::string& file, const test::TempDir& dir,
                              std::vector<Row>* samples = nullptr) {
  const auto out = dir.path() / "out";
  const auto r = test::run_cli({"run", file, "--out", out.string(), "--quiet", "--jobs", "2"});
  INFO(r.output);
  REQUIRE(r.code == 0);
  if (samples) *samples = test::read_csv(out / "samples.csv");
  return test::read_csv(out / "points.csv");
}

// Mean of `column` over the rows matching every (column, value) of `where`.
double mean(const std::vector<Row>& rows, const std::map<std::string, std::string>& where,
            const std::string& column) {
  double sum = 0.0;
  int n = 0;
  for (const auto& r : rows) {
    bool match = true;
    for (const auto& [k, v] : where)
      match &= r.at(k) == v;
    if (!match) continue;
    sum += test::num(r, column);
    ++n;
  }
  INFO("no rows for " << column);
  REQUIRE(n > 0);
  return sum / n;
}

std::vector<double> samples_of(const std::vector<Row>& samples, const std::string& point,
                               const std::string& kind) {
  std::vector<double> v;
  for (const auto& s : samples)
    if (s.at("point") == point && s.at("kind") == kind) v.push_back(std::stod(s.at("value_us")));
  std::sort(v.begin(), v.end());
  return v;
}

const std::vector<std::string> kThresholds = {"5", "10", "15", "20", "25", "30"};

}  // namespace

TEST_CASE("exp1: the PMC callback takes about 15 us, with little variation, at every period",
          "[sim][fidelity]") {
  test::TempDir dir;
  std::vector<Row> samples;
  const auto rows = run_scenario("scenarios/paper/exp1-pmc-callback.json", dir, &samples);
  int checked = 0;
  for (const auto& r : rows) {
    if (r.at("sampling") != "self") continue;
    const auto v = samples_of(samples, r.at("point"), "pmc_callback");
    INFO("sampling period " << r.at("sampling_period_us") << " us");
    REQUIRE(v.size() > 10);
    CHECK(test::num(r, "pmc_callback_p50_us") == Approx(15.0).margin(1.0));
    CHECK(v.back() - v.front() < 5.0);  // min and max stay close to the median
    ++checked;
  }
  CHECK(checked == 18);
}

TEST_CASE(
    "exp2: self-sampling costs bandwidth_read ~5.9 % at 1 ms, less at longer periods, "
    "too much below 100 us - external sampling costs nothing noticeable",
    "[sim][fidelity]") {
  test::TempDir dir;
  const auto rows = run_scenario("scenarios/paper/exp2-sampling-overhead.json", dir);
  const auto slowdown = [&](const std::string& sampling, int period) {
    return mean(rows, {{"sampling", sampling}, {"sampling_period_us", std::to_string(period)}},
                "nrt_slowdown");
  };
  CHECK(slowdown("self", 1000) == Approx(1.059).margin(0.01));
  const std::vector<int> periods = {100, 200, 500, 1000, 2000, 5000};
  for (std::size_t i = 1; i < periods.size(); ++i) {
    INFO("self-sampling every " << periods[i] << " us vs " << periods[i - 1] << " us");
    CHECK(slowdown("self", periods[i]) < slowdown("self", periods[i - 1]));
  }
  CHECK(slowdown("self", 500) < 1.15);  // "low from 500 us upwards"
  CHECK(slowdown("self", 100) > 1.5);   // "below 100 us excessive"
  for (int p : periods) {
    INFO("external sampling every " << p << " us");
    CHECK(slowdown("external", p) < 1.005);
  }
}

TEST_CASE(
    "exp3: activation delay below 200 us self and 100 us external, external lower, both "
    "nearly constant across periods, external medians close to the minima",
    "[sim][fidelity]") {
  test::TempDir dir;
  std::vector<Row> samples;
  const auto rows = run_scenario("scenarios/paper/exp3-activation-delay.json", dir, &samples);
  std::map<std::string, std::vector<double>> medians;  // per sampling mode
  for (const auto& r : rows) {
    const std::string mode = r.at("sampling");
    const auto v = samples_of(samples, r.at("point"), "activation_delay");
    if (v.empty()) continue;  // no throttle in this run (e.g. 5 ms sampling in a 10 ms period)
    INFO(mode << " sampling every " << r.at("sampling_period_us") << " us");
    const double med = v[v.size() / 2];
    CHECK(v.back() < (mode == "self" ? 200.0 : 100.0));
    if (mode == "external") CHECK(med - v.front() < 0.2 * med);
    medians[mode].push_back(med);
  }
  REQUIRE(medians["self"].size() >= 4);
  REQUIRE(medians["external"].size() >= 4);
  for (auto& [mode, m] : medians) {
    const double avg = std::accumulate(m.begin(), m.end(), 0.0) / static_cast<double>(m.size());
    for (double x : m) {
      INFO(mode << " median " << x << " vs mean of medians " << avg);
      CHECK(std::abs(x - avg) < 0.1 * avg);  // nearly constant across sampling periods
    }
  }
  CHECK(*std::max_element(medians["external"].begin(), medians["external"].end()) <
        *std::min_element(medians["self"].begin(), medians["self"].end()));
}

TEST_CASE("exp4: a lower threshold gives an RT slowdown not higher and an nRT slowdown not lower",
          "[sim][fidelity]") {
  test::TempDir dir;
  const auto rows = run_scenario("scenarios/paper/exp4-setpoint.json", dir);
  for (const std::string pair : {"bandwidth_read", "mser"})
    for (const std::string policy : {"interval", "monolithic"})
      for (std::size_t i = 1; i < kThresholds.size(); ++i) {
        const std::map<std::string, std::string> lo = {{"rt_workload", pair},
                                                       {"nrt_workload", pair},
                                                       {"policy", policy},
                                                       {"threshold_pct", kThresholds[i - 1]}};
        auto hi = lo;
        hi["threshold_pct"] = kThresholds[i];
        INFO(pair << " pair, " << policy << ", threshold " << kThresholds[i - 1] << " % vs "
                  << kThresholds[i] << " %");
        // 1 % allowance: the paper's saturation plateaus, where seeds alone make the difference.
        CHECK(mean(rows, lo, "rt_slowdown") <= mean(rows, hi, "rt_slowdown") * 1.01);
        CHECK(mean(rows, lo, "nrt_slowdown") >= mean(rows, hi, "nrt_slowdown") * 0.99);
      }
  // And regulation works at all: at 5 % the RT node is far closer to isolation than at 30 %.
  for (const std::string pair : {"bandwidth_read", "mser"}) {
    const std::map<std::string, std::string> at5 = {{"rt_workload", pair},
                                                    {"nrt_workload", pair},
                                                    {"policy", "interval"},
                                                    {"threshold_pct", "5"}};
    auto at30 = at5;
    at30["threshold_pct"] = "30";
    CHECK(mean(rows, at5, "rt_slowdown") < mean(rows, at30, "rt_slowdown"));
    CHECK(mean(rows, at5, "nrt_slowdown") > 1.5 * mean(rows, at30, "nrt_slowdown") - 0.5);
  }
}

TEST_CASE(
    "exp4: monolithic over-penalises the nRT node while interval barely affects the RT "
    "node and gives better overall throughput, at the same threshold",
    "[sim][fidelity]") {
  test::TempDir dir;
  const auto rows = run_scenario("scenarios/paper/exp4-setpoint.json", dir);
  for (const std::string pair : {"bandwidth_read", "mser"})
    for (const auto& t : kThresholds) {
      const std::map<std::string, std::string> in = {{"rt_workload", pair},
                                                     {"nrt_workload", pair},
                                                     {"policy", "interval"},
                                                     {"threshold_pct", t}};
      auto mono = in;
      mono["policy"] = "monolithic";
      // Where the nRT node's whole demand stays below the threshold a monolithic budget never
      // runs out (mser uses ~13 % of the reference bandwidth in this co-run): the paper's claim
      // is about thresholds where regulation binds, which is every threshold for bandwidth_read.
      if (mean(rows, mono, "throttle_count") == 0) continue;
      INFO(pair << " pair at " << t << " %");
      const double rt_in = mean(rows, in, "rt_slowdown"), rt_mono = mean(rows, mono, "rt_slowdown");
      const double nrt_in = mean(rows, in, "nrt_slowdown"),
                   nrt_mono = mean(rows, mono, "nrt_slowdown");
      CHECK(nrt_mono > nrt_in);
      // Not reproduced for the bandwidth_read pair (the [!shouldfail] case below).
      if (pair == "bandwidth_read") continue;
      CHECK(rt_in - rt_mono < 0.2);
      // Throughput: the work both nodes complete per unit time, relative to isolation. Not in
      // saturation (bandwidth_read at 5-10 %: the nRT node runs one sampling period per
      // regulation period): there each REPLENISH makes the nRT node refill its 2 MB, evicting
      // the RT node's lines, every 5 ms (sim/README.md, refill after throttling); at 10 % the
      // sum is 1.028 (interval) vs 1.032 (monolithic).
      if (pair == "bandwidth_read" && std::stoi(t) <= 10) continue;
      CHECK(1 / rt_in + 1 / nrt_in > 1 / rt_mono + 1 / nrt_mono);
    }
  // Regulation binds for mser at the lowest thresholds.
  CHECK(mean(rows,
             {{"rt_workload", "mser"},
              {"nrt_workload", "mser"},
              {"policy", "monolithic"},
              {"threshold_pct", "5"}},
             "nrt_slowdown") > mean(rows,
                                    {{"rt_workload", "mser"},
                                     {"nrt_workload", "mser"},
                                     {"policy", "interval"},
                                     {"threshold_pct", "5"}},
                                    "nrt_slowdown"));
}

// Paper findings the shared-LRU L3 model (model/cache/shared_lru.h) does not reproduce. Each
// case checks the paper's statement as before and is expected to fail ([!shouldfail]: it
// passes while some check fails, and fails once the statement holds again, so that its mark is
// removed). The reason, with the numbers of make reproduce (sim/README.md, "What it changes"):
// two 2 MB streams on one cluster both miss in the 2 MB L3 (each needs 2 MB - 256 KB of it,
// the L3 being exclusive of the L2), so a bandwidth_read pair is DRAM-bound; the nRT copy then
// moves about 7.05 GB/s unregulated, below 25-30 % of the 26.3 GB/s reference (never throttled
// there), and at lower thresholds every REPLENISH makes it evict the RT node's lines again.
TEST_CASE(
    "exp4 (not reproduced: bandwidth_read pair DRAM-bound): interval barely affects the RT node "
    "and gives better throughput than monolithic",
    "[sim][fidelity][!shouldfail]") {
  test::TempDir dir;
  const auto rows = run_scenario("scenarios/paper/exp4-setpoint.json", dir);
  for (const auto& t : kThresholds) {
    const std::map<std::string, std::string> in = {{"rt_workload", "bandwidth_read"},
                                                   {"nrt_workload", "bandwidth_read"},
                                                   {"policy", "interval"},
                                                   {"threshold_pct", t}};
    auto mono = in;
    mono["policy"] = "monolithic";
    INFO("bandwidth_read pair at " << t << " %");
    const double rt_in = mean(rows, in, "rt_slowdown"), rt_mono = mean(rows, mono, "rt_slowdown");
    const double nrt_in = mean(rows, in, "nrt_slowdown"),
                 nrt_mono = mean(rows, mono, "nrt_slowdown");
    CHECK(rt_in - rt_mono < 0.2);  // 15 %: 1.84 vs 1.40; 30 %: 3.51 vs 1.80
    if (std::stoi(t) > 10) CHECK(1 / rt_in + 1 / nrt_in > 1 / rt_mono + 1 / nrt_mono);
  }
}

TEST_CASE(
    "exp4: saturation below ~10 % (throttled after one sampling period), and "
    "bandwidth_read exhausts its budget even at 30 % (not reproduced: at 5 % nRT 16.97, at 10 % "
    "8.86, no throttle at 25-30 %)",
    "[sim][fidelity][!shouldfail]") {
  test::TempDir dir;
  const auto rows = run_scenario("scenarios/paper/exp4-setpoint.json", dir);
  const std::map<std::string, std::string> bw = {{"rt_workload", "bandwidth_read"},
                                                 {"nrt_workload", "bandwidth_read"},
                                                 {"policy", "interval"}};
  auto at5 = bw, at10 = bw;
  at5["threshold_pct"] = "5";
  at10["threshold_pct"] = "10";
  CHECK(mean(rows, at5, "nrt_slowdown") == Approx(mean(rows, at10, "nrt_slowdown")).epsilon(0.02));
  CHECK(mean(rows, at5, "rt_slowdown") == Approx(mean(rows, at10, "rt_slowdown")).epsilon(0.02));
  for (const auto& t : kThresholds) {
    auto p = bw;
    p["threshold_pct"] = t;
    // One throttle per 5 ms regulation period over the RT node's run.
    const double periods = mean(rows, p, "rt_time_us") / 5000.0;
    INFO("bandwidth_read pair at " << t << " %: " << periods << " regulation periods");
    CHECK(mean(rows, p, "throttle_count") >= std::floor(periods) - 1);
  }
}

TEST_CASE(
    "exp5: looser sampling (regulation 5x sampling) lowers the nRT overhead, but only "
    "for thresholds above ~10 %",
    "[sim][fidelity]") {
  test::TempDir dir;
  const auto rows = run_scenario("scenarios/paper/exp5-sampling-period.json", dir);
  const auto nrt = [&](int period, const std::string& t) {
    return mean(rows, {{"sampling_period_us", std::to_string(period)}, {"threshold_pct", t}},
                "nrt_slowdown");
  };
  for (const std::string t : {"15", "20", "25", "30"}) {
    INFO("threshold " << t << " %");
    CHECK(nrt(1000, t) < nrt(500, t));
    CHECK(nrt(2000, t) < nrt(1000, t));
    CHECK(nrt(2000, t) < 0.95 * nrt(500, t));
  }
  // At 5 % the budget is gone after the first sample whatever the period: the nRT node runs a
  // fifth of each regulation period either way. What looser sampling still saves there is
  // refills: a quarter as many throttle episodes, each followed by a refill of what the RT node
  // evicted meanwhile (nRT 2.06 at 500 us, 1.94 at 2 ms). It gains less than at any threshold
  // where throttling is not saturated.
  // The paper's "only above ~10 %": looser sampling gains less at 5 % than anywhere else (the
  // case below).
}

TEST_CASE("exp5: looser sampling gains least at 5 %, where the budget is gone after one sample",
          "[sim][fidelity]") {
  test::TempDir dir;
  const auto rows = run_scenario("scenarios/paper/exp5-sampling-period.json", dir);
  const auto nrt = [&](int period, const std::string& t) {
    return mean(rows, {{"sampling_period_us", std::to_string(period)}, {"threshold_pct", t}},
                "nrt_slowdown");
  };
  // From 250 us to 2 ms, as the paper's statement and tools/paper_table.py compare (make
  // reproduce, the profiles fitted with the system-level cache): at 5 % 2.03 -> 1.95 (-4 %), at
  // 10-30 % -14 to -20 %. (From 500 us, 10 % gains least: 500 us and 1 ms sampling leave the
  // node throttled alike there, 1.37 both, and 2 ms gains 2.4 % against 6.1 % at 5 %.)
  const double gain5 = 1.0 - nrt(2000, "5") / nrt(250, "5");
  for (const std::string t : {"10", "15", "20", "25", "30"}) {
    INFO("threshold " << t << " %");
    CHECK(gain5 < 1.0 - nrt(2000, t) / nrt(250, t));
  }
}

TEST_CASE(
    "exp6: longer regulation periods penalise a bandwidth_read nRT node and protect the "
    "RT node more - for mser they change little",
    "[sim][fidelity]") {
  test::TempDir dir;
  const auto rows = run_scenario("scenarios/paper/exp6-regulation-period.json", dir);
  const auto at = [&](const std::string& w, int period, const std::string& col) {
    return mean(
        rows,
        {{"rt_workload", w}, {"nrt_workload", w}, {"regulation_period_us", std::to_string(period)}},
        col);
  };
  // The bandwidth_read pair's statement: the case below.
  double lo = 1e9, hi = 0.0;
  for (int p : {1000, 2000, 3000, 4000, 5000}) {
    lo = std::min(lo, at("mser", p, "nrt_slowdown"));
    hi = std::max(hi, at("mser", p, "nrt_slowdown"));
  }
  CHECK(hi - lo < 0.03);
}

TEST_CASE(
    "exp6: a bandwidth_read nRT node throttled at 30 % (its L3 misses hit in the system-level "
    "cache) - longer regulation periods penalise it and protect the RT node more",
    "[sim][fidelity]") {
  test::TempDir dir;
  const auto rows = run_scenario("scenarios/paper/exp6-regulation-period.json", dir);
  const auto at = [&](int period, const std::string& col) {
    return mean(rows,
                {{"rt_workload", "bandwidth_read"},
                 {"nrt_workload", "bandwidth_read"},
                 {"regulation_period_us", std::to_string(period)}},
                col);
  };
  // 1 ms -> 5 ms: nRT 2.30 -> 3.18, RT 2.03 -> 1.59 (make reproduce). Without the system-level
  // cache the pair is DRAM-bound, never throttled at 30 %, and both periods give nRT 3.96, RT 3.50.
  CHECK(at(5000, "nrt_slowdown") > 1.1 * at(1000, "nrt_slowdown"));
  CHECK(at(5000, "rt_slowdown") < at(1000, "rt_slowdown"));
}

TEST_CASE(
    "exp7: high-bandwidth nRT nodes are slowed most - external sampling penalises the nRT node "
    "less",
    "[sim][fidelity]") {
  test::TempDir dir;
  const auto rows = run_scenario("scenarios/paper/exp7-grid.json", dir);
  const std::set<std::string> high = {"bandwidth_read", "bandwidth_write"};
  double self_sum = 0.0, ext_sum = 0.0;
  for (const auto& r : rows) {
    const std::string nrt = r.at("nrt_workload");
    INFO("RT " << r.at("rt_workload") << ", nRT " << nrt << ", " << r.at("sampling") << " "
               << r.at("sampling_period_us") << " us, " << r.at("threshold_pct") << " %");
    // The RT side and the low-bandwidth nRT side are not reproduced everywhere: the
    // [!shouldfail] case below.
    if (high.count(nrt)) CHECK(test::num(r, "nrt_slowdown") > 2.0);
    if (r.at("sampling_period_us") == "1000")
      (r.at("sampling") == "self" ? self_sum : ext_sum) += test::num(r, "nrt_slowdown");
  }
  CHECK(ext_sum < self_sum);
}

TEST_CASE(
    "exp7 (not reproduced against bandwidth_read / mser co-runners): the RT node close to "
    "isolation everywhere, low-bandwidth nRT nodes slowed little",
    "[sim][fidelity][!shouldfail]") {
  // RT bandwidth_read beside nRT bandwidth_read up to 3.52 (both DRAM-bound, as in exp. 4),
  // beside nRT mser 1.73 (mser's insertions take more than the 256 KB the stream leaves);
  // stitch as nRT beside an RT stream up to 1.44. Beside sift, tracking, stitch, disparity the
  // RT node stays within 1.05.
  test::TempDir dir;
  const auto rows = run_scenario("scenarios/paper/exp7-grid.json", dir);
  const std::set<std::string> high = {"bandwidth_read", "bandwidth_write"};
  const std::set<std::string> low = {"sift", "stitch", "tracking"};
  for (const auto& r : rows) {
    const std::string nrt = r.at("nrt_workload");
    INFO("RT " << r.at("rt_workload") << ", nRT " << nrt << ", " << r.at("sampling") << " "
               << r.at("sampling_period_us") << " us, " << r.at("threshold_pct") << " %");
    const double rt = test::num(r, "rt_slowdown");
    CHECK(rt < 1.35);
    if (!high.count(nrt)) CHECK(rt < 1.12);
    if (low.count(nrt)) CHECK(test::num(r, "nrt_slowdown") < 1.35);
  }
}

TEST_CASE(
    "exp8: at 200 us sampling the self-sampling overhead is visible on the nRT node and "
    "external sampling removes it",
    "[sim][fidelity]") {
  test::TempDir dir;
  const auto rows = run_scenario("scenarios/paper/exp8-memguard.json", dir);
  for (const std::string n : {"disparity", "mser", "sift", "stitch", "tracking"})
    for (const std::string t : {"20", "30", "40"}) {
      INFO(n << " at " << t << " %");
      const double self = mean(
          rows, {{"nrt_workload", n}, {"sampling", "self"}, {"threshold_pct", t}}, "nrt_slowdown");
      const double ext =
          mean(rows, {{"nrt_workload", n}, {"sampling", "external"}, {"threshold_pct", t}},
               "nrt_slowdown");
      // ~56 us of every 200 us period go to sampling: 1 / (1 - 0.28) = 1.39 in isolation.
      CHECK(self / ext > 1.2);
      CHECK(self / ext < 1.6);
    }
}

TEST_CASE(
    "exp8: ROSGuard protects the RT node as MemGuard does at the same thresholds, and its "
    "self-sampling costs the nRT node more than MemGuard on sift, stitch and tracking",
    "[sim][fidelity]") {
  test::TempDir dir;
  const auto rows = run_scenario("scenarios/paper/exp8-memguard.json", dir);
  const std::map<std::string, std::string> memguard = {{"policy", "memguard"},
                                                       {"sampling", "overflow"}};
  const double mg_rt = mean(rows, memguard, "rt_slowdown");
  for (const std::string mode : {"self", "external"}) {
    const double rt = mean(rows, {{"policy", "interval"}, {"sampling", mode}}, "rt_slowdown");
    INFO(mode << ": RT slowdown " << rt << " vs MemGuard " << mg_rt);
    CHECK(std::abs(rt / mg_rt - 1) <= 0.10);  // paper_table.py: COMPARABLE
  }
  for (const std::string n : {"sift", "stitch", "tracking"})
    for (const std::string t : {"20", "30", "40"}) {
      INFO(n << " at " << t << " %");
      const double self = mean(
          rows, {{"nrt_workload", n}, {"sampling", "self"}, {"threshold_pct", t}}, "nrt_slowdown");
      const double mg =
          mean(rows, {{"nrt_workload", n}, {"policy", "memguard"}, {"threshold_pct", t}},
               "nrt_slowdown");
      CHECK(self > mg * 1.005);  // paper_table.py: NOISE
    }
}

TEST_CASE(
    "unregulated co-runs: two bandwidth_read copies on one cluster thrash the L3, on two "
    "clusters barely slow each other - two mser copies moderately",
    "[sim][fidelity]") {
  test::TempDir dir;
  const nlohmann::json doc = {
      {"name", "unregulated"},
      {"nodes",
       {{"controller", {{"core", 0}}},
        {"rt", {{{"name", "rt0"}, {"core", 1}, {"workload", "bandwidth_read"}}}},
        {"nrt", {{{"name", "nrt0"}, {"core", 2}, {"workload", "bandwidth_read"}}}}}},
      {"regulation", {{"policy", "none"}}},
      {"sweep",
       {{"nodes.rt[0].workload", {"bandwidth_read", "mser"}}, {"nodes.nrt[0].core", {2, 5}}}}};
  const auto file = dir.path() / "unregulated.json";
  std::ofstream(file) << doc.dump(2);
  const auto rows = run_scenario(file.string(), dir);
  const auto rt = [&](const std::string& w, const std::string& core) {
    return mean(rows, {{"rt_workload", w}, {"param:nodes.nrt[0].core", core}}, "rt_slowdown");
  };
  // Two 2 MB streams in one 2 MB L3 both miss (LRU; each needs 2 MB - 256 KB of an L3
  // exclusive of its L2): DRAM-bound. (The former capacity exponent was calibrated to 1.6x.)
  CHECK(rt("bandwidth_read", "2") > 2.0);
  CHECK(rt("bandwidth_read", "5") < 1.05);
  CHECK(rt("mser", "2") > 1.05);
  CHECK(rt("mser", "5") < rt("mser", "2"));
}

TEST_CASE(
    "loop nRT time compares the same work: a phased nRT on another cluster, unregulated, is "
    "not slowed",
    "[sim][fidelity]") {
  // The RT node (a light one) on cluster 0, the nRT on cluster 1: no shared L3, and too little
  // DRAM traffic to load it. The RT window falls somewhere among the nRT's phases; the slowdown
  // compares the window with the isolation time of exactly the instructions retired in it
  // (model/engine/outcome.h), so it is 1 whatever the phases (dividing by the fraction of a run
  // done instead gave sift 1.025). On orin-agx without its system-level cache, which all
  // clusters share (there the RT node's misses take some of it: nRT up to 1.04).
  test::TempDir dir;
  nlohmann::json platform = nlohmann::json::parse(
      test::read_text(test::source_dir() / "scenarios/platforms/orin-agx.json"));
  platform["memory"].erase("slc");
  platform["name"] = "orin-agx-no-slc";
  std::ofstream(dir.path() / "orin-no-slc.json") << platform.dump(2);
  const nlohmann::json doc = {
      {"name", "phased-nrt-apart"},
      {"platform", "orin-no-slc.json"},
      {"nodes",
       {{"controller", {{"core", 0}}},
        {"rt", {{{"name", "rt0"}, {"core", 1}, {"workload", "tracking"}}}},
        {"nrt", {{{"name", "nrt0"}, {"core", 5}, {"workload", "sift"}}}}}},
      {"regulation", {{"policy", "none"}}},
      {"sweep", {{"nodes.nrt[0].workload", {"sift", "mser", "disparity", "stitch", "tracking"}}}}};
  const auto file = dir.path() / "apart.json";
  std::ofstream(file) << doc.dump(2);
  for (const auto& r : run_scenario(file.string(), dir)) {
    INFO(r.at("nrt_workload") << ": nRT slowdown " << r.at("nrt_slowdown"));
    CHECK(std::abs(test::num(r, "nrt_slowdown") - 1.0) < 0.005);
    CHECK(test::num(r, "nrt_runs") > 0.0);
  }
}

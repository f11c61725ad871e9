// The precision of a point's slowdowns and the rule that stops repeating it
// (model/results/precision.h; docs/design.md section 5, hw.precision_pct): Student t quantiles,
// the confidence interval of a mean, which baseline measurement belongs to which round, the
// per-round slowdown CIs, the stopping rule, and the CI cells of points.csv.
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "results/precision.h"
#include "results/results.h"

using namespace rosguard;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

BaselineRuns runs_of(std::initializer_list<double> times) {
  BaselineRuns r;
  int rep = 0;
  for (double t : times)
    r.runs[rep++] = {t, kNaN, kNaN};
  return r;
}

MeanCi ci_of(int n, double pct) {
  MeanCi ci;
  ci.n = n;
  ci.mean = 1.0;
  ci.half_width = n >= 2 ? pct / 100.0 : kNaN;
  return ci;
}

Scenario two_node_scenario() {
  Scenario s;
  s.backend = "hw";
  s.platform.name = "p";
  s.document = {{"sim", {{"quantum_us", 10}}}, {"hw", {{"pmc_source", "auto"}}}};
  s.nodes.rt.push_back({"rt0", 0, {"rt_work", "inline", {{"hw", {{"kernel", "a"}}}}}, 3, 1000});
  s.nodes.nrt.push_back(
      {"nrt0", 1, {"nrt_work", "inline", {{"hw", {{"kernel", "b"}}}}}, NrtMode::Loop});
  return s;
}

}  // namespace

TEST_CASE("Student t: the table and the expansion beyond it", "[precision]") {
  CHECK(student_t95(1) == Approx(12.7062).epsilon(1e-5));
  CHECK(student_t95(2) == Approx(4.3027).epsilon(1e-5));
  CHECK(student_t95(10) == Approx(2.2281).epsilon(1e-5));
  CHECK(student_t95(30) == Approx(2.0423).epsilon(1e-5));
  // Exact values t_{0.975, df} (R: qt(0.975, df)).
  CHECK(student_t95(31) == Approx(2.039513).margin(1e-4));
  CHECK(student_t95(40) == Approx(2.021075).margin(1e-4));
  CHECK(student_t95(60) == Approx(2.000298).margin(1e-4));
  CHECK(student_t95(120) == Approx(1.979930).margin(1e-4));
  CHECK(student_t95(100000) == Approx(1.959964).margin(1e-4));
  for (int df = 1; df < 200; ++df)
    CHECK(student_t95(df + 1) < student_t95(df));  // decreasing towards the normal quantile
  CHECK_THROWS_AS(student_t95(0), ContractError);
}

TEST_CASE("the 95 % confidence interval of a mean", "[precision]") {
  // 1, 2, 3: mean 2, s = 1, half-width t(2) x 1 / sqrt(3).
  const MeanCi three = mean_ci95({1.0, 2.0, 3.0});
  CHECK(three.n == 3);
  CHECK(three.mean == Approx(2.0));
  CHECK(three.half_width == Approx(4.3027 / std::sqrt(3.0)).epsilon(1e-5));
  CHECK(three.half_width_pct() == Approx(100.0 * 4.3027 / std::sqrt(3.0) / 2.0).epsilon(1e-5));

  // NaN values (not measured) are left out.
  const MeanCi with_nan = mean_ci95({1.0, kNaN, 2.0, 3.0});
  CHECK(with_nan.n == 3);
  CHECK(with_nan.half_width == Approx(three.half_width));

  // Identical values: a zero-width interval.
  CHECK(mean_ci95({1.5, 1.5, 1.5, 1.5}).half_width_pct() == 0.0);

  // One value or none: no interval.
  const MeanCi one = mean_ci95({1.2});
  CHECK(one.n == 1);
  CHECK(one.mean == 1.2);
  CHECK(std::isnan(one.half_width_pct()));
  const MeanCi none = mean_ci95({});
  CHECK(none.n == 0);
  CHECK(std::isnan(none.mean));
  CHECK(std::isnan(none.half_width_pct()));
  // A zero mean has no relative precision.
  CHECK(std::isnan(mean_ci95({-1.0, 1.0}).half_width_pct()));
}

TEST_CASE("the baseline of a round: measured before it, else the median of all", "[precision]") {
  const BaselineRuns b = runs_of({100.0, 110.0, 120.0, 130.0});
  // Adaptive rounds: measurement r before round r.
  const RoundPairing adaptive{1, 1, true};
  CHECK(round_baseline_us(b, 0, adaptive) == 100.0);
  CHECK(round_baseline_us(b, 3, adaptive) == 130.0);
  CHECK(round_baseline_us(b, 4, adaptive) == 115.0);  // none yet: the median of all
  // Fixed plan, 2 rounds, 4 measurements: k = 0, 1 before round 0; k = 2, 3 before round 1.
  const RoundPairing fixed{2, 4, false};
  CHECK(round_baseline_us(b, 0, fixed) == 105.0);
  CHECK(round_baseline_us(b, 1, fixed) == 125.0);
  // sim: one measurement, before round 0; every round uses it.
  const BaselineRuns once = runs_of({200.0});
  CHECK(round_baseline_us(once, 0, RoundPairing{3, 1, false}) == 200.0);
  CHECK(round_baseline_us(once, 2, RoundPairing{3, 1, false}) == 200.0);
  CHECK(std::isnan(round_baseline_us(BaselineRuns{}, 0, adaptive)));
}

TEST_CASE("slowdown CIs come from per-round ratios: drift on both sides cancels", "[precision]") {
  // The machine slows down by 10 % per round; the co-run and its round's baseline alike. The
  // ratios are all 1.5, so the CI is zero, although the times spread by 30 %.
  const BaselineRuns rt = runs_of({100.0, 110.0, 120.0, 130.0});
  const BaselineRuns nrt = runs_of({50.0, 50.0, 50.0, 50.0});
  std::map<int, std::vector<double>> times;
  for (int r = 0; r < 4; ++r)
    times[r] = {1.5 * (100.0 + 10.0 * r), 50.0 + r};
  const auto cis = slowdown_cis({&rt, &nrt}, times, RoundPairing{1, 1, true});
  REQUIRE(cis.size() == 2);
  CHECK(cis[0].n == 4);
  CHECK(cis[0].mean == Approx(1.5));
  CHECK(cis[0].half_width_pct() == Approx(0.0).margin(1e-9));
  // nRT: ratios 1.00, 1.02, 1.04, 1.06.
  CHECK(cis[1].mean == Approx(1.03));
  const double s = std::sqrt((0.03 * 0.03 + 0.01 * 0.01) * 2 / 3);
  CHECK(cis[1].half_width == Approx(student_t95(3) * s / 2.0).epsilon(1e-6));

  // Against the median of all baselines (the fixed plan of one round, every measurement before
  // it) the drift would widen the RT CI.
  const auto unpaired = slowdown_cis({&rt, &nrt}, times, RoundPairing{1, 4, false});
  CHECK(unpaired[0].half_width_pct() > 10.0);

  // A node without a baseline has no CI (n 0); a missing time is left out.
  times[2][1] = kNaN;
  const auto partial = slowdown_cis({&rt, nullptr}, times, RoundPairing{1, 1, true});
  CHECK(partial[0].n == 4);
  CHECK(partial[1].n == 0);
  CHECK(slowdown_cis({&rt, &nrt}, times, RoundPairing{1, 1, true})[1].n == 3);
}

TEST_CASE("the rule: fixed repetitions, or at least 3 rounds up to the cap", "[precision]") {
  const PrecisionRule fixed = precision_rule(5, std::nullopt, 20);
  CHECK(fixed.min_rounds == 5);
  CHECK(fixed.max_rounds == 5);
  const PrecisionRule adaptive = precision_rule(1, 2.0, 20);
  CHECK(adaptive.min_rounds == kMinAdaptiveRounds);
  CHECK(adaptive.max_rounds == 20);
  CHECK(precision_rule(6, 2.0, 20).min_rounds == 6);  // repetitions is the minimum
  CHECK(precision_rule(1, 2.0, 2).min_rounds == 2);   // a cap below 3 lowers the minimum
  CHECK(precision_rule(1, 2.0, 2).max_rounds == 2);
}

TEST_CASE("the stopping rule", "[precision]") {
  const PrecisionRule rule = precision_rule(1, 2.0, 6);
  // Fewer than the minimum: more, whatever the CIs.
  CHECK(judge_rounds(rule, 2, {ci_of(2, 0.1)}) == RoundsVerdict::More);
  // Every CI within the target: precise.
  CHECK(judge_rounds(rule, 3, {ci_of(3, 1.9), ci_of(3, 2.0)}) == RoundsVerdict::Precise);
  // One outside: more, until the cap.
  CHECK(judge_rounds(rule, 3, {ci_of(3, 1.0), ci_of(3, 2.1)}) == RoundsVerdict::More);
  CHECK(judge_rounds(rule, 5, {ci_of(5, 1.0), ci_of(5, 2.1)}) == RoundsVerdict::More);
  CHECK(judge_rounds(rule, 6, {ci_of(6, 1.0), ci_of(6, 2.1)}) == RoundsVerdict::Capped);
  // Precise at the cap is precise.
  CHECK(judge_rounds(rule, 6, {ci_of(6, 1.0)}) == RoundsVerdict::Precise);
  // A slowdown the point does not have (n 0) is not judged; one that cannot be computed is not
  // within the target.
  CHECK(judge_rounds(rule, 3, {ci_of(0, 0.0), ci_of(3, 1.0)}) == RoundsVerdict::Precise);
  MeanCi zero_mean = ci_of(3, 1.0);
  zero_mean.mean = 0.0;
  CHECK(judge_rounds(rule, 3, {zero_mean}) == RoundsVerdict::More);
  // Nothing to judge: precise once the minimum ran.
  CHECK(judge_rounds(rule, 3, {}) == RoundsVerdict::Precise);
  // Without a target: the fixed rounds, then done.
  const PrecisionRule fixed = precision_rule(3, std::nullopt, 20);
  CHECK(judge_rounds(fixed, 2, {ci_of(2, 50.0)}) == RoundsVerdict::More);
  CHECK(judge_rounds(fixed, 3, {ci_of(3, 50.0)}) == RoundsVerdict::Fixed);

  CHECK(widest_ci_pct({ci_of(3, 1.0), ci_of(0, 0.0), ci_of(3, 4.0), ci_of(1, 0.0)}) == Approx(4.0));
  CHECK(std::isnan(widest_ci_pct({ci_of(1, 0.0)})));
}

TEST_CASE("points.csv: every row of a point carries the point's slowdown CIs", "[precision]") {
  const Scenario s = two_node_scenario();
  const auto header = points_header(1, 1, {});
  for (const char* c : {"rt_slowdown_ci95_pct", "nrt_slowdown_ci95_pct"})
    CHECK(std::find(header.begin(), header.end(), c) != header.end());
  Baselines b;
  const auto& rt = s.nodes.rt[0];
  const auto& nrt = s.nodes.nrt[0];
  for (int r = 0; r < 3; ++r) {
    b.put(Baselines::key(s, rt.workload, rt.core), {100.0, kNaN, kNaN}, r);
    b.put(Baselines::key(s, nrt.workload, nrt.core), {50.0, kNaN, kNaN}, r);
  }
  const std::vector<double> rt_times = {150.0, 160.0, 170.0};
  std::vector<std::string> lines;
  for (int r = 0; r < 3; ++r) {
    PointOutcome o;
    o.rt.push_back({"rt0", rt_times[static_cast<std::size_t>(r)], 3, {}, -1});
    o.nrt.push_back({"nrt0", 60.0, 0.0, 0, 0.0, 1.0});
    std::string line = points_row(header, SweepPoint{0, "p1", {}, {}}, s, r, o, b);
    line.pop_back();
    lines.push_back(line);
    // Written as the run ends: no CI yet.
    CHECK(row_node_times(header, csv_split(line), s) ==
          std::vector<double>{rt_times[static_cast<std::size_t>(r)], 60.0});
  }
  const auto filled = fill_ci_cells(header, lines, s, b, RoundPairing{3, 3, false});
  REQUIRE(filled.size() == 3);
  // RT ratios 1.5, 1.6, 1.7: mean 1.6, s 0.1; nRT ratios all 1.2: 0.
  const double rt_pct = 100.0 * student_t95(2) * 0.1 / std::sqrt(3.0) / 1.6;
  for (const auto& line : filled) {
    const auto cells = csv_split(line);
    const auto at = [&](const std::string& column) {
      return cells.at(static_cast<std::size_t>(std::find(header.begin(), header.end(), column) -
                                               header.begin()));
    };
    CHECK(std::stod(at("rt_slowdown_ci95_pct")) == Approx(rt_pct).margin(1e-3));
    CHECK(at("nrt_slowdown_ci95_pct") == "0.000");
  }
  // One row alone has no CI: the cells stay empty.
  const auto single = fill_ci_cells(header, {lines[0]}, s, b, RoundPairing{1, 3, false});
  CHECK(single[0] == lines[0]);
  // Without the baselines: empty as well.
  CHECK(fill_ci_cells(header, lines, s, Baselines{}, RoundPairing{3, 3, false}) == lines);
}

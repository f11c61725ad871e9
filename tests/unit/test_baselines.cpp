// Repeated isolation baselines (docs/design.md, sections 5 and 6): the median and spread of a
// baseline's measurements, the noise warning, where measurements go between repetition rounds,
// how a points.csv row is brought up to date when more measurements arrive, and the RT jobs'
// response times in samples.csv.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <limits>
#include <tuple>

#include "core/hash.h"
#include "engine/outcome.h"
#include "results/results.h"

using namespace rosguard;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

BaselineRuns runs_of(std::initializer_list<double> times) {
  BaselineRuns r;
  int rep = 0;
  for (double t : times)
    r.runs[rep++] = {t, 1.0 + rep, 100.0 * rep};
  return r;
}

// A scenario with one RT and one nRT node, enough for points_row (no loader involved).
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

std::string cell(const std::vector<std::string>& header, const std::string& line,
                 const std::string& column) {
  const auto cells = csv_split(line);
  const auto it = std::find(header.begin(), header.end(), column);
  REQUIRE(it != header.end());
  return cells.at(static_cast<std::size_t>(it - header.begin()));
}

}  // namespace

TEST_CASE("a baseline's median and coefficient of variation", "[baselines]") {
  const BaselineRuns three = runs_of({110.0, 100.0, 90.0});
  CHECK(three.count() == 3);
  CHECK(three.median().time_us == 100.0);
  CHECK(three.median().ipc == 3.0);       // field by field: ipc 2, 3, 4
  CHECK(three.time_cv() == Approx(0.1));  // sample std 10 / mean 100

  const BaselineRuns two = runs_of({100.0, 104.0});
  CHECK(two.median().time_us == 102.0);
  CHECK(two.time_cv() == Approx(std::sqrt(8.0) / 102.0));

  // One measurement has no spread; a NaN field (no IPC on this host) stays NaN, and a NaN time
  // does not move the median of the others.
  const BaselineRuns one = runs_of({100.0});
  CHECK(std::isnan(one.time_cv()));
  CHECK_FALSE(one.too_noisy());
  BaselineRuns with_nan = runs_of({100.0, 102.0, 98.0});
  with_nan.runs[3] = {kNaN, kNaN, kNaN};
  CHECK(with_nan.median().time_us == 100.0);
  BaselineRuns no_ipc;
  no_ipc.runs[0] = {100.0, kNaN, kNaN};
  no_ipc.runs[1] = {101.0, kNaN, kNaN};
  CHECK(std::isnan(no_ipc.median().ipc));
}

TEST_CASE("a baseline spread above 5 % is too noisy and says so", "[baselines]") {
  // cv = 0.049 and 0.051: sample std of {100 - d, 100, 100 + d} is d.
  const BaselineRuns quiet = runs_of({95.1, 100.0, 104.9});
  const BaselineRuns noisy = runs_of({94.9, 100.0, 105.1});
  CHECK(quiet.time_cv() == Approx(0.049));
  CHECK(noisy.time_cv() == Approx(0.051));
  CHECK_FALSE(quiet.too_noisy());
  CHECK(noisy.too_noisy());
  CHECK(quiet.noise_warning("w/core0/x").empty());
  const std::string w = noisy.noise_warning("w/core0/x");
  CHECK_THAT(w, Catch::StartsWith("isolation baseline w/core0/x: "));
  CHECK_THAT(w, Catch::Contains("5.1 %"));
  CHECK_THAT(w, Catch::Contains("over 3 measurements"));
}

TEST_CASE("a baseline's key hashes backend, platform, workload, sim and hw", "[baselines]") {
  Scenario s = two_node_scenario();
  s.platform.doc = {{"cores", 2}, {"name", "p"}};
  const WorkloadInfo& w = s.nodes.rt[0].workload;
  const auto expected = [&](const Scenario& sc) {
    char hashes[40];
    std::snprintf(hashes, sizeof hashes, "/%016llx/%016llx/",
                  static_cast<unsigned long long>(fnv1a(sc.platform.doc.dump())),
                  static_cast<unsigned long long>(fnv1a(w.doc.dump())));
    const std::string text =
        sc.backend + hashes + sc.document.at("sim").dump() + sc.document.at("hw").dump();
    char hex[20];
    std::snprintf(hex, sizeof hex, "%08llx",
                  static_cast<unsigned long long>(fnv1a(text) & 0xffffffffULL));
    return "rt_work/core0/" + std::string(hex);
  };
  CHECK(Baselines::key(s, w, 0) == expected(s));
  // Each part changes it: the backend, the platform, the workload, the settings, the core.
  Scenario other = s;
  other.backend = "sim";
  CHECK(Baselines::key(other, w, 0) == expected(other));
  CHECK(Baselines::key(other, w, 0) != Baselines::key(s, w, 0));
  other = s;
  other.platform.doc = {{"cores", 4}, {"name", "p"}};
  CHECK(Baselines::key(other, w, 0) != Baselines::key(s, w, 0));
  CHECK(Baselines::key(s, s.nodes.nrt[0].workload, 0) != Baselines::key(s, w, 0));
  other = s;
  other.document["sim"]["quantum_us"] = 20;
  CHECK(Baselines::key(other, w, 0) != Baselines::key(s, w, 0));
  CHECK(Baselines::key(s, w, 1) != Baselines::key(s, w, 0));
  // How many times a baseline is measured is not part of it.
  other = s;
  other.document["hw"]["baseline_repetitions"] = 5;
  CHECK(Baselines::key(other, w, 0) == Baselines::key(s, w, 0));
}

TEST_CASE("baseline measurements are spread over the repetition rounds", "[baselines]") {
  // As many measurements as rounds: one before each.
  for (int k = 0; k < 3; ++k)
    CHECK(baseline_round(k, 3, 3) == k);
  // One round, three measurements: all before it (the round needs them for its rows).
  for (int k = 0; k < 3; ++k)
    CHECK(baseline_round(k, 1, 3) == 0);
  // Two rounds, three measurements: two before the first, one before the second.
  CHECK(baseline_round(0, 2, 3) == 0);
  CHECK(baseline_round(1, 2, 3) == 0);
  CHECK(baseline_round(2, 2, 3) == 1);
  // Never after the last round.
  for (int m = 1; m < 20; ++m)
    for (int r = 1; r <= m; ++r)
      for (int k = 0; k < m; ++k) {
        CHECK(baseline_round(k, r, m) >= 0);
        CHECK(baseline_round(k, r, m) < r);
      }
}

TEST_CASE("a row written with the first baseline is refreshed with the median of all",
          "[baselines]") {
  const Scenario s = two_node_scenario();
  const SweepPoint point{0, "p0", {}, {}};
  const auto header = points_header(1, 1, {});
  PointOutcome o;
  o.rt.push_back(rt_outcome("rt0", std::vector<double>{120e3, 130e3},
                            std::vector<double>{120e3, 1200e3}, 1000e3));
  o.nrt.push_back({"nrt0", 500.0, 10.0, 0, 0.0, 1.0});
  const std::string rt_key = Baselines::key(s, s.nodes.rt[0].workload, 0);
  const std::string nrt_key = Baselines::key(s, s.nodes.nrt[0].workload, 1);

  Baselines b;
  b.put(rt_key, {80.0, kNaN, kNaN}, 0);  // the outlier, measured first
  b.put(nrt_key, {250.0, kNaN, kNaN}, 0);
  std::string row = points_row(header, point, s, 0, o, b);
  row.pop_back();  // '\n'
  CHECK(cell(header, row, "rt_isolation_us") == "80.000");
  CHECK(cell(header, row, "rt_isolation_n") == "1");
  CHECK(cell(header, row, "rt_isolation_cv").empty());
  CHECK(cell(header, row, "rt_slowdown") == "1.562500");
  // Response times: job 1 released at 1000 us finished 1200 us later, past its period.
  CHECK(cell(header, row, "rt_response_max_us") == "1200.000");
  CHECK(cell(header, row, "rt_deadline_misses") == "1");
  // Nothing new: the row stays as written.
  CHECK_FALSE(refresh_isolation_cells(header, row, s, b).has_value());

  b.put(rt_key, {100.0, kNaN, kNaN}, 1);
  b.put(rt_key, {104.0, kNaN, kNaN}, 2);
  b.put(nrt_key, {250.0, kNaN, kNaN}, 1);
  b.put(nrt_key, {250.0, kNaN, kNaN}, 2);
  const auto fresh = refresh_isolation_cells(header, row, s, b);
  REQUIRE(fresh.has_value());
  CHECK(cell(header, *fresh, "rt_isolation_us") == "100.000");
  CHECK(cell(header, *fresh, "rt_isolation_n") == "3");
  CHECK(std::stod(cell(header, *fresh, "rt_isolation_cv")) ==
        Approx(b.all().at(rt_key).time_cv()).margin(1e-6));
  CHECK(cell(header, *fresh, "rt_slowdown") == "1.250000");
  CHECK(cell(header, *fresh, "nrt_isolation_n") == "3");
  CHECK(cell(header, *fresh, "nrt_isolation_cv") == "0.000000");
  CHECK(cell(header, *fresh, "nrt_slowdown") == "2.000000");
  // Measured cells are untouched.
  for (const char* c : {"rt_time_us", "nrt_time_us", "rt_response_max_us", "rt_deadline_misses"})
    CHECK(cell(header, *fresh, c) == cell(header, row, c));
  // And the refreshed row is final.
  CHECK_FALSE(refresh_isolation_cells(header, *fresh, s, b).has_value());
  // A baseline the folder does not hold leaves the row alone.
  CHECK_FALSE(refresh_isolation_cells(header, row, s, Baselines{}).has_value());
}

TEST_CASE(
    "adjacent baselines: each point has its own, and a repetition divides by its own "
    "measurement",
    "[baselines]") {
  Scenario s = two_node_scenario();
  const WorkloadInfo& rt_work = s.nodes.rt[0].workload;
  Scenario other = s;
  other.document["regulation"] = {{"threshold_pct", 40}};
  // Without the setting, two points of one sweep share their baselines.
  CHECK(Baselines::key(s, rt_work, 0) == Baselines::key(other, rt_work, 0));
  s.hw.adjacent_baselines = other.hw.adjacent_baselines = true;
  s.document["hw"]["adjacent_baselines"] = other.document["hw"]["adjacent_baselines"] = true;
  CHECK(Baselines::key(s, rt_work, 0) != Baselines::key(other, rt_work, 0));
  // How often a point repeats does not change one measurement.
  Scenario more = s;
  more.document["repetitions"] = 9;
  CHECK(Baselines::key(s, rt_work, 0) == Baselines::key(more, rt_work, 0));

  const SweepPoint point{0, "p0", {}, {}};
  const auto header = points_header(1, 1, {});
  PointOutcome o;
  o.rt.push_back(
      rt_outcome("rt0", std::vector<double>{120e3}, std::vector<double>{120e3}, std::nullopt));
  o.nrt.push_back({"nrt0", 500.0, 10.0, 0, 0.0, 1.0});
  Baselines b;
  const std::string rt_key = Baselines::key(s, rt_work, 0);
  const std::string nrt_key = Baselines::key(s, s.nodes.nrt[0].workload, 1);
  // The machine ran fast, then slow: repetition 2 ran in the slow phase with its baseline.
  for (const auto& [k, rt, nrt] :
       {std::tuple{0, 60.0, 250.0}, {1, 62.0, 250.0}, {2, 100.0, 400.0}}) {
    b.put(rt_key, {rt, kNaN, kNaN}, k);
    b.put(nrt_key, {nrt, kNaN, kNaN}, k);
  }
  std::string row = points_row(header, point, s, 2, o, b);
  row.pop_back();
  CHECK(cell(header, row, "rt_isolation_us") == "100.000");
  CHECK(cell(header, row, "rt_slowdown") == "1.200000");
  CHECK(cell(header, row, "nrt_isolation_us") == "400.000");
  CHECK(cell(header, row, "nrt_slowdown") == "1.250000");
  CHECK(cell(header, row, "rt_isolation_n") == "3");
  // The median (62) would have said 1.935.
  row = points_row(header, point, s, 0, o, b);
  row.pop_back();
  CHECK(cell(header, row, "rt_slowdown") == "2.000000");
  // A refresh keeps each repetition's own measurement.
  CHECK_FALSE(refresh_isolation_cells(header, row, s, b).has_value());
}

TEST_CASE("every node's columns name it: name, core and throttling, the first nodes too",
          "[baselines][results]") {
  Scenario s = two_node_scenario();
  s.nodes.nrt.push_back(
      {"tracking", 3, {"track_work", "inline", {{"hw", {{"kernel", "c"}}}}}, NrtMode::Loop});
  const auto header = points_header(1, 2, {});
  PointOutcome o;
  o.rt.push_back(
      rt_outcome("rt0", std::vector<double>{100.0}, std::vector<double>{100.0}, std::nullopt));
  o.nrt.push_back({"nrt0", 500.0, 10.0, 7, 40.0, 1.0});
  o.nrt.push_back({"tracking", 900.0, 20.0, 11, 90.0, 1.0});
  Baselines b;
  b.put(Baselines::key(s, s.nodes.rt[0].workload, 0), {50.0, kNaN, kNaN}, 0);
  for (const auto& n : s.nodes.nrt)
    b.put(Baselines::key(s, n.workload, n.core), {250.0, kNaN, kNaN}, 0);
  std::string row = points_row(header, SweepPoint{0, "p0", {}, {}}, s, 0, o, b);
  row.pop_back();
  CHECK(cell(header, row, "rt_name") == "rt0");
  CHECK(cell(header, row, "rt_core") == "0");
  CHECK(cell(header, row, "nrt_name") == "nrt0");
  CHECK(cell(header, row, "nrt_core") == "1");
  CHECK(cell(header, row, "nrt_throttle_count") == "7");
  CHECK(cell(header, row, "throttle_count") == "7");  // the fixed name of the same value
  CHECK(cell(header, row, "nrt_throttled_us") == "40.000");
  CHECK(cell(header, row, "throttled_us") == "40.000");
  CHECK(cell(header, row, "nrt1_name") == "tracking");
  CHECK(cell(header, row, "nrt1_core") == "3");
  CHECK(cell(header, row, "nrt1_workload") == "track_work");
  CHECK(cell(header, row, "nrt1_throttle_count") == "11");
  CHECK(cell(header, row, "nrt1_throttled_us") == "90.000");
  CHECK(cell(header, row, "nrt1_slowdown") == "3.600000");
}

TEST_CASE("each RT job's response time is a samples.csv row of kind rt_job", "[baselines]") {
  PointOutcome o;
  o.samples.push_back({"activation_delay", 5.0});
  o.rt.push_back(rt_outcome("rt0", std::vector<double>{1e3, 2e3, 3e3},
                            std::vector<double>{1e3, 2e3, 4e3}, std::nullopt));
  o.rt.push_back(rt_outcome("rt1", std::vector<double>{7e3}, std::vector<double>{7e3}, 5e3));
  CHECK(o.rt[0].deadline_misses == -1);  // no period, no deadline
  CHECK(o.rt[1].deadline_misses == 1);
  CHECK(samples_rows("p0", 2, o) ==
        "p0,2,activation_delay,5.000\n"
        "p0,2,rt_job,1.000\n"
        "p0,2,rt_job,2.000\n"
        "p0,2,rt_job,4.000\n"
        "p0,2,rt1_job,7.000\n");
}

TEST_CASE("percentile interpolates between ranks as numpy does", "[results]") {
  CHECK(percentile({1, 2, 3, 4, 5}, 50) == 3);
  CHECK(percentile({1, 2, 3, 4, 5}, 99) == Approx(4.96));
  CHECK(percentile({7}, 99) == 7);
  CHECK(std::isnan(percentile({}, 99)));
}

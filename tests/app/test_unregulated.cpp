// The unregulated co-run (tools/rosguard/run/unregulated.h): which points share one, the scenario
// it runs, the points.csv cells it fills, and DIR/unregulated.json.
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "results/results.h"
#include "run/unregulated.h"

using namespace rosguard;
namespace fs = std::filesystem;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

Scenario point(const std::string& policy, double threshold) {
  Scenario s;
  s.backend = "sim";
  s.seed = 1;
  s.platform.name = "p";
  s.platform.doc = {{"name", "p"}};
  s.regulation.policy = policy;
  s.regulation.threshold_pct = threshold;
  s.regulation.sampling_period_us = 500;
  s.document = {{"name", "a"},
                {"repetitions", 3},
                {"seed", 1},
                {"sim", {{"quantum_us", 10}}},
                {"hw", {{"baseline_repetitions", 3}}},
                {"nodes", {{"rt", {{{"core", 1}}}}, {"nrt", {{{"core", 2}}}}}},
                {"regulation",
                 {{"policy", policy}, {"threshold_pct", threshold}, {"sampling_period_us", 500}}}};
  s.nodes.rt.push_back({"rt0", 1, {"mser", "inline", {{"w", 1}}}, 1, std::nullopt});
  s.nodes.nrt.push_back({"nrt0", 2, {"bandwidth_read", "inline", {{"w", 2}}}, NrtMode::Loop});
  return s;
}

std::string cell(const std::vector<std::string>& header, const std::string& line,
                 const std::string& column) {
  const auto cells = csv_split(line);
  const auto it = std::find(header.begin(), header.end(), column);
  REQUIRE(it != header.end());
  return cells.at(static_cast<std::size_t>(it - header.begin()));
}

// A points.csv line of `s` with RT / nRT co-run times 150 / 300 and isolation 100 / 200.
std::string row_of(const std::vector<std::string>& header, const Scenario& s, Baselines& b) {
  b.put(Baselines::key(s, s.nodes.rt[0].workload, 1), {100.0, 1.0, 10.0});
  b.put(Baselines::key(s, s.nodes.nrt[0].workload, 2), {200.0, 1.0, 10.0});
  PointOutcome o;
  o.rt.push_back({"rt0", 150.0, 1, {150.0}, -1});
  o.nrt.push_back({"nrt0", 300.0, 10.0, 0, 0.0, 1.0});
  std::string row = points_row(header, {0, "p0", {}, {}}, s, 0, o, b);
  row.pop_back();
  return row;
}

}  // namespace

TEST_CASE("every regulation setting of a workload pair shares one unregulated co-run",
          "[unregulated]") {
  const std::string key = UnregulatedCoruns::key(point("interval", 20));
  CHECK(key.rfind("corun/mser+bandwidth_read/", 0) == 0);
  CHECK(UnregulatedCoruns::key(point("monolithic", 5)) == key);
  Scenario other_period = point("interval", 20);
  other_period.document["regulation"]["sampling_period_us"] = 200;
  other_period.document["repetitions"] = 5;
  other_period.document["hw"]["baseline_repetitions"] = 7;
  CHECK(UnregulatedCoruns::key(other_period) == key);
  // ... but not another core, workload, platform or sim setting.
  Scenario core = point("interval", 20);
  core.document["nodes"]["nrt"][0]["core"] = 3;
  Scenario workload = point("interval", 20);
  workload.nodes.nrt[0].workload.doc = {{"w", 3}};
  Scenario platform = point("interval", 20);
  platform.platform.doc = {{"name", "q"}};
  Scenario quantum = point("interval", 20);
  quantum.document["sim"]["quantum_us"] = 5;
  for (const Scenario* s : {&core, &workload, &platform, &quantum})
    CHECK(UnregulatedCoruns::key(*s) != key);
}

TEST_CASE("the co-run runs with regulation off and nothing of the point's setting",
          "[unregulated]") {
  const Scenario a = UnregulatedCoruns::scenario_of(point("interval", 5));
  const Scenario b = UnregulatedCoruns::scenario_of(point("monolithic", 30));
  CHECK(a.regulation.policy == "none");
  CHECK(a.regulation.threshold_pct == b.regulation.threshold_pct);
  CHECK(a.regulation.sampling_period_us == RegulationSpec{}.sampling_period_us);
  CHECK(a.document["regulation"] == b.document["regulation"]);
  CHECK(a.document["regulation"]["policy"] == "none");
  CHECK(UnregulatedCoruns::needed(point("interval", 5)));
  CHECK_FALSE(UnregulatedCoruns::needed(point("none", 5)));
  Scenario alone = point("interval", 5);
  alone.nodes.nrt.clear();
  CHECK_FALSE(UnregulatedCoruns::needed(alone));
}

TEST_CASE("a row gets the co-run's median over its isolation, a policy-none row its own",
          "[unregulated]") {
  const auto header = points_header(1, 1, {});
  const Scenario s = point("interval", 20);
  Baselines b;
  const std::string row = row_of(header, s, b);
  UnregulatedCoruns coruns;
  // Not measured (yet): the line stays as it is.
  const std::string key = UnregulatedCoruns::key(s);
  CHECK(fill_unregulated_cells(header, row, s, key, coruns, b) == row);
  coruns.put(key, {{380.0}, {210.0}}, 0);
  coruns.put(key, {{400.0}, {kNaN}}, 1);  // a measurement that lacks the nRT time
  coruns.put(key, {{420.0}, {230.0}}, 2);
  const std::string filled = fill_unregulated_cells(header, row, s, key, coruns, b);
  CHECK(cell(header, filled, "rt_unregulated_time_us") == "400.000");
  CHECK(cell(header, filled, "rt_unregulated_slowdown") == "4.000000");
  CHECK(cell(header, filled, "nrt_unregulated_time_us") == "220.000");
  CHECK(cell(header, filled, "nrt_unregulated_slowdown") == "1.100000");
  CHECK(cell(header, filled, "rt_slowdown") == cell(header, row, "rt_slowdown"));

  const Scenario none = point("none", 20);
  const std::string own =
      fill_unregulated_cells(header, row_of(header, none, b), none, "", coruns, b);
  CHECK(cell(header, own, "rt_unregulated_time_us") == "150.000");
  CHECK(cell(header, own, "rt_unregulated_slowdown") == "1.500000");
  CHECK(cell(header, own, "nrt_unregulated_slowdown") == "1.500000");
}

TEST_CASE("every node's unregulated cells are filled, the second nRT node's too", "[unregulated]") {
  const auto header = points_header(1, 2, {});
  Scenario s = point("interval", 20);
  s.document["nodes"]["nrt"].push_back({{"core", 3}});
  s.nodes.nrt.push_back({"disp", 3, {"disparity", "inline", {{"w", 3}}}, NrtMode::Loop});
  Baselines b;
  b.put(Baselines::key(s, s.nodes.rt[0].workload, 1), {100.0, 1.0, 10.0});
  b.put(Baselines::key(s, s.nodes.nrt[0].workload, 2), {200.0, 1.0, 10.0});
  b.put(Baselines::key(s, s.nodes.nrt[1].workload, 3), {50.0, 1.0, 10.0});
  PointOutcome o;
  o.rt.push_back({"rt0", 150.0, 1, {150.0}, -1});
  o.nrt.push_back({"nrt0", 300.0, 10.0, 0, 0.0, 1.0});
  o.nrt.push_back({"disp", 60.0, 10.0, 0, 0.0, 1.0});
  std::string row = points_row(header, {0, "p0", {}, {}}, s, 0, o, b);
  row.pop_back();
  UnregulatedCoruns coruns;
  const std::string key = UnregulatedCoruns::key(s);
  coruns.put(key, {{400.0}, {220.0, 80.0}}, 0);
  const std::string filled = fill_unregulated_cells(header, row, s, key, coruns, b);
  CHECK(cell(header, filled, "nrt_unregulated_slowdown") == "1.100000");
  CHECK(cell(header, filled, "nrt1_unregulated_time_us") == "80.000");
  CHECK(cell(header, filled, "nrt1_unregulated_slowdown") == "1.600000");
  // With policy none each node carries its own.
  Scenario none = s;
  none.regulation.policy = "none";
  std::string own = points_row(header, {0, "p0", {}, {}}, none, 0, o, b);
  own.pop_back();
  own = fill_unregulated_cells(header, own, none, "", coruns, b);
  CHECK(cell(header, own, "nrt1_unregulated_time_us") == cell(header, own, "nrt1_time_us"));
  CHECK(cell(header, own, "nrt1_unregulated_slowdown") == "1.200000");
}

TEST_CASE("unregulated.json keeps every measurement and merges other writers'", "[unregulated]") {
  const fs::path dir = fs::temp_directory_path() / ("rosguard-unreg-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  CHECK(UnregulatedCoruns::read(dir).all().empty());
  UnregulatedCoruns first;
  first.put("k", {{1.0}, {kNaN}}, 0);
  first.save(dir);
  UnregulatedCoruns second;
  second.put("k", {{9.0}, {9.0}}, 0);  // the same index: the one on file is kept
  second.put("k", {{3.0}, {4.0}}, 1);
  second.save(dir);
  const UnregulatedCoruns back = UnregulatedCoruns::read(dir);
  REQUIRE(back.all().at("k").size() == 2);
  CHECK(back.all().at("k").at(0).rt_time_us == std::vector<double>{1.0});
  CHECK(std::isnan(back.all().at("k").at(0).nrt_time_us.at(0)));  // null: not measured
  CHECK(back.median("k")->rt_time_us == std::vector<double>{2.0});
  CHECK(back.median("k")->nrt_time_us == std::vector<double>{4.0});
  std::ofstream(dir / "unregulated.json") << R"({"k": {"runs": [{"rep": "x"}]}})";
  CHECK_THROWS_AS(UnregulatedCoruns::read(dir), RunError);
  fs::remove_all(dir);
}

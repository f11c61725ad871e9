// One regulation setup (regulator/setup.h): built once from a RegulationSpec, validated with the
// run's registry, periods in ns; what the regulator is made of.
#include <catch2/catch.hpp>
#include <string>
#include <vector>

#include "core/error.h"
#include "policy/builtin_registry.h"
#include "regulator/setup.h"
#include "results/results.h"

using namespace rosguard;

namespace {

RegulationSpec interval_spec() {
  RegulationSpec r;
  r.policy = "interval";
  r.sampling = Sampling::Self;
  r.sampling_period_us = 250;
  r.regulation_period_us = 1250;
  r.threshold_pct = 20.0;
  r.reference_mbps = 1000.0;
  r.scope = Scope::Core;
  return r;
}

Scenario monolithic_scenario() {
  Scenario s;
  s.file = "point.json";
  s.backend = "sim";
  s.document = {{"sim", {{"quantum_us", 10}}}, {"hw", {{"pmc_source", "auto"}}}};
  s.nodes.rt.push_back({"rt0", 0, {"rt_work", "inline", {{"sim", {{"k", 1}}}}}, 1, {}});
  s.nodes.nrt.push_back({"nrt0", 1, {"nrt_work", "inline", {{"sim", {{"k", 2}}}}}, NrtMode::Loop});
  s.regulation = interval_spec();
  s.regulation.policy = "monolithic";
  return s;
}

}  // namespace

TEST_CASE("a regulation setup: the policy, its parameters in ns, the accounts", "[setup]") {
  const RegulationSetup setup =
      regulation_setup(interval_spec(), {1, 2}, builtin_registry(), "a.json");
  CHECK(setup.policy.name == "interval");
  CHECK(setup.regulates());
  CHECK(setup.sampling == Sampling::Self);
  CHECK(setup.sampling_period_ns == 250'000);
  CHECK(setup.params.regulation_period_ns == 1'250'000);
  CHECK(setup.params.threshold_pct == 20.0);
  CHECK(setup.params.reference_mbps == 1000.0);
  CHECK(setup.params.monolithic_window_ns == 0);

  const RegulatorConfig rc = setup.regulator_config();
  CHECK(rc.rt_count == 1);
  CHECK(rc.account_of_entity == std::vector<std::size_t>{0, 1});  // scope core: one each

  // The policy it makes sizes a window's budget from those: 20 % of 1000 MB/s over 1.25 ms.
  std::vector<Account> accounts(2);
  setup.make_policy()->open_window(0, accounts);
  CHECK(accounts[0].budget_bytes == Approx(0.2 * 1000.0 * 1048576.0 * 0.00125));
  CHECK(setup.make_regulator() != nullptr);
  CHECK(setup.describe() ==
        "interval, self sampling every 250 us, 20 % of 1000 MB/s per 1250 us window, scope core");

  SECTION("scope group: one account for every nRT node; no RT node still one activation") {
    RegulationSpec r = interval_spec();
    r.scope = Scope::Group;
    const RegulationSetup g = regulation_setup(r, {0, 3}, builtin_registry(), "a.json");
    CHECK(g.regulator_config().account_of_entity == std::vector<std::size_t>{0, 0, 0});
    CHECK(g.regulator_config().rt_count == 1);
  }
  SECTION("budgets per nRT node replace threshold x reference") {
    RegulationSpec r = interval_spec();
    r.budget_mbps = {100.0, 300.0};
    const RegulationSetup b = regulation_setup(r, {1, 2}, builtin_registry(), "a.json");
    CHECK(account_rate_mbps(b.params, 1) == 300.0);
    CHECK_THAT(b.describe(), Catch::Contains("budget 100 / 300 MB/s"));
  }
}

TEST_CASE("a regulation setup refuses what its policy cannot run, naming file and path",
          "[setup]") {
  const auto error_of = [](const RegulationSpec& r, RegulatedNodes nodes) {
    try {
      regulation_setup(r, nodes, builtin_registry(), "guard.json");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  RegulationSpec r = interval_spec();
  r.policy = "nosuch";
  CHECK_THAT(error_of(r, {1, 1}), Catch::StartsWith("guard.json: /regulation/policy:") &&
                                      Catch::Contains("unknown policy 'nosuch'"));
  r = interval_spec();
  r.sampling_period_us = r.regulation_period_us;
  CHECK_THAT(error_of(r, {1, 1}),
             Catch::StartsWith("guard.json: /regulation/sampling_period_us:") &&
                 Catch::Contains("equals the regulation period"));
  r = interval_spec();
  r.policy = "monolithic";
  CHECK_THAT(error_of(r, {0, 1}), Catch::StartsWith("guard.json: /regulation/policy:") &&
                                      Catch::Contains("there is no RT node"));
}

TEST_CASE("a point's setup takes its monolithic window from the baselines, rounded to ns",
          "[setup]") {
  const Scenario s = monolithic_scenario();
  CHECK(regulation_setup(s, builtin_registry()).params.monolithic_window_ns == 0);
  Baselines b;
  IsolationResult iso;
  iso.time_us = 12345.6786;
  b.put(Baselines::key(s, s.nodes.rt[0].workload, 0), iso);
  const RegulationSetup setup = regulation_setup(s, builtin_registry(), &b);
  CHECK(setup.params.monolithic_window_ns == 12'345'679);
  CHECK_THAT(setup.describe(), Catch::Contains("per RT execution"));
}

TEST_CASE("points.csv reports the sampling a point ran with, not only the scenario's",
          "[setup][results]") {
  Scenario s = monolithic_scenario();
  s.regulation.policy = "memguard";
  s.regulation.sampling = Sampling::Overflow;
  const std::vector<std::string> header = points_header(1, 1, {});
  SweepPoint point;
  point.id = "0";
  Baselines b;
  for (const auto* w : {&s.nodes.rt[0].workload, &s.nodes.nrt[0].workload}) {
    IsolationResult iso;
    iso.time_us = 100.0;
    b.put(Baselines::key(s, *w, w == &s.nodes.rt[0].workload ? 0 : 1), iso);
  }
  PointOutcome o;
  o.rt.push_back({"rt0", 150.0, 1, {150.0}, -1});
  o.nrt.push_back({"nrt0", 200.0, 10.0, 0, 0.0, 1.0});
  const auto column = [&](const std::string& row, const std::string& name) {
    const auto cells = csv_split(row.substr(0, row.size() - 1));
    const auto it = std::find(header.begin(), header.end(), name);
    REQUIRE(it != header.end());
    return cells.at(static_cast<std::size_t>(it - header.begin()));
  };
  const std::string as_asked = points_row(header, point, s, 0, o, b);
  CHECK(column(as_asked, "sampling") == "overflow");
  CHECK(column(as_asked, "sampling_period_us") == "250");
  // The hw backend without overflow counters ran external sampling every 100 us instead.
  o.sampling = RanSampling{Sampling::External, 100'000};
  const std::string ran = points_row(header, point, s, 0, o, b);
  CHECK(column(ran, "sampling") == "external");
  CHECK(column(ran, "sampling_period_us") == "100");
}

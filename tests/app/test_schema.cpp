// Schema validation messages and defaults (tools/rosguard/load/schema.h), tested directly on
// documents: the text a user reads is rendered from the schema node at the failing path.
#include <catch2/catch.hpp>
#include <fstream>
#include <set>
#include <string>

#include "load/loader.h"
#include "load/schema.h"
#include "policy/policy.h"

using namespace rosguard;
using json = nlohmann::json;
using Catch::Matchers::EndsWith;

namespace {

const SchemaSet& schemas() {
  static const SchemaSet set(Home::locate().schemas());
  return set;
}

// A valid scenario document; tests break one thing at a time.
json scenario() {
  return json::parse(R"({"name": "t", "backend": "hw", "nodes": {
    "controller": {"core": 0},
    "rt": [{"name": "rt0", "core": 1, "workload": "mser"}],
    "nrt": [{"name": "nrt0", "core": 2, "workload": "mser"}]}})");
}

json workload() {
  return json::parse(R"({"name": "w",
    "sim": {"instructions": 1e9, "phases": [{"fraction": 1, "base_ipc": 1, "l2_refill_pki": 2,
                                             "l2_wb_pki": 1}]},
    "hw": {"kernel": "proxy"}})");
}

std::pair<std::string, std::string> error_of(const json& doc,
                                             SchemaKind kind = SchemaKind::Scenario) {
  const auto err = schemas().first_error(doc, kind);
  REQUIRE(err.has_value());
  return *err;
}

}  // namespace

TEST_CASE("schema: valid documents have no error", "[schema]") {
  CHECK_FALSE(schemas().first_error(scenario(), SchemaKind::Scenario).has_value());
  CHECK_FALSE(schemas().first_error(workload(), SchemaKind::Workload).has_value());
}

TEST_CASE("schema: unknown keys list what is allowed and suggest a near name", "[schema]") {
  SECTION("a near miss gets a did-you-mean") {
    json doc = scenario();
    doc["regulation"] = {{"polcy", "interval"}};
    CHECK(error_of(doc) == std::pair<std::string, std::string>{
                               "/regulation/polcy",
                               "unknown key 'polcy' (did you mean 'policy'?); allowed here: "
                               "budget_mbps, event_budget_mbps, global_budget_mbps, metric, "
                               "policy, reclaim, reference_mbps, regulation_period_us, "
                               "sampling, sampling_period_us, scope, sharing, threshold_pct"});
  }
  SECTION("a far-off name gets no suggestion") {
    json doc = scenario();
    doc["regulation"] = {{"xyzzy", 1}};
    CHECK(error_of(doc).second ==
          "unknown key 'xyzzy'; allowed here: budget_mbps, event_budget_mbps, "
          "global_budget_mbps, metric, policy, reclaim, reference_mbps, regulation_period_us, "
          "sampling, sampling_period_us, scope, sharing, threshold_pct");
  }
  SECTION("at the top level, without the editor's $schema key") {
    json doc = scenario();
    doc["nmae"] = "x";
    CHECK(error_of(doc) ==
          std::pair<std::string, std::string>{
              "/nmae",
              "unknown key 'nmae' (did you mean 'name'?); allowed here: backend, "
              "description, hw, name, nodes, platform, regulation, repetitions, seed, "
              "sim, sweep"});
  }
  SECTION("inside an array item") {
    json doc = scenario();
    doc["nodes"]["rt"][0]["iteration"] = 3;
    CHECK(error_of(doc) ==
          std::pair<std::string, std::string>{
              "/nodes/rt/0/iteration",
              "unknown key 'iteration' (did you mean 'iterations'?); allowed here: core, "
              "iterations, name, period_us, signal, workload"});
  }
}

TEST_CASE("schema: enum errors list the allowed values", "[schema]") {
  json w = workload();
  w["hw"]["kernel"] = "stream";
  CHECK(
      error_of(w, SchemaKind::Workload) ==
      std::pair<std::string, std::string>{
          "/hw/kernel",
          R"(must be one of "bandwidth_read", "bandwidth_write", "latency", "proxy", not "stream")"});
  json doc = scenario();
  doc["regulation"] = {{"policy", 3}};
  CHECK(
      error_of(doc).second ==
      R"(must be one of "interval", "monolithic", "monitor", "none", "memguard", "mempol", not 3)");
}

TEST_CASE("schema: range errors say which bounds are inclusive", "[schema]") {
  SECTION("exclusive lower bound only") {
    json doc = scenario();
    doc["regulation"] = {{"reference_mbps", 0}};
    CHECK(error_of(doc) ==
          std::pair<std::string, std::string>{"/regulation/reference_mbps", "must be > 0, not 0"});
  }
  SECTION("inclusive lower bound only") {
    json w = workload();
    w["sim"]["footprint_kb"] = -0.5;
    CHECK(error_of(w, SchemaKind::Workload) ==
          std::pair<std::string, std::string>{"/sim/footprint_kb", "must be >= 0, not -0.5"});
  }
  SECTION("exclusive lower, inclusive upper") {
    json w = workload();
    w["sim"]["phases"][0]["fraction"] = 1.5;
    CHECK(error_of(w, SchemaKind::Workload).second == "must be in (0, 1], not 1.5");
    w["sim"]["phases"][0]["fraction"] = 0;
    CHECK(error_of(w, SchemaKind::Workload).second == "must be in (0, 1], not 0");
  }
  SECTION("inclusive both ways") {
    json doc = scenario();
    doc["nodes"]["rt"][0]["iterations"] = 0;
    CHECK(error_of(doc) == std::pair<std::string, std::string>{"/nodes/rt/0/iterations",
                                                               "must be in [1, 100000], not 0"});
    doc["nodes"]["rt"][0]["iterations"] = 100001;
    CHECK(error_of(doc).second == "must be in [1, 100000], not 100001");
  }
}

TEST_CASE("schema: type errors name the expected and the given type", "[schema]") {
  json doc = scenario();
  SECTION("integer vs string") {
    doc["nodes"]["controller"]["core"] = "3";
    CHECK(error_of(doc) ==
          std::pair<std::string, std::string>{"/nodes/controller/core",
                                              R"(must be an integer, not a string ("3"))"});
  }
  SECTION("object vs boolean") {
    doc["regulation"] = true;
    CHECK(error_of(doc) == std::pair<std::string, std::string>{
                               "/regulation", "must be an object, not a boolean (true)"});
  }
  SECTION("one of two types") {
    doc["nodes"]["nrt"][0]["workload"] = 5;
    CHECK(error_of(doc).second == "must be a string or an object, not an integer (5)");
  }
  SECTION("list vs number, and null") {
    doc["sweep"] = {{"regulation.threshold_pct", 2.5}};
    CHECK(error_of(doc) ==
          std::pair<std::string, std::string>{"/sweep/regulation.threshold_pct",
                                              "must be a list, not a number (2.5)"});
    doc = scenario();
    doc["description"] = nullptr;
    CHECK(error_of(doc).second == "must be a string, not null (null)");
  }
  SECTION("long values are cut") {
    doc["description"] = json::array();
    for (int i = 0; i < 40; ++i)
      doc["description"].push_back(i);
    const std::string shown = json(doc["description"]).dump().substr(0, 57) + "...";
    CHECK(error_of(doc).second == "must be a string, not a list (" + shown + ")");
  }
}

TEST_CASE("schema: integers above INT64_MAX are compared as they are written", "[schema]") {
  // valijson's nlohmann adapter reads integers as int64_t: 2^64 - 1 used to be -1 there.
  json doc = scenario();
  SECTION("the whole u64 range is a seed") {
    for (const char* seed :
         {"0", "9223372036854775807", "9223372036854775808", "18446744073709551615"}) {
      doc["seed"] = json::parse(seed);
      CHECK_FALSE(schemas().first_error(doc, SchemaKind::Scenario).has_value());
    }
  }
  SECTION("a bound they break is still reported, with the value as written") {
    doc["nodes"]["rt"][0]["iterations"] = json::parse("18446744073709551615");
    CHECK(error_of(doc) ==
          std::pair<std::string, std::string>{"/nodes/rt/0/iterations",
                                              "must be in [1, 100000], not 18446744073709551615"});
  }
  SECTION("without an upper bound of 2^63 or more a field takes no more than INT64_MAX") {
    // period_us has no maximum and is read as an int64_t.
    doc["nodes"]["rt"][0]["period_us"] = json::parse("9223372036854775807");
    CHECK_FALSE(schemas().first_error(doc, SchemaKind::Scenario).has_value());
    doc["nodes"]["rt"][0]["period_us"] = json::parse("9223372036854775808");
    CHECK(error_of(doc) ==
          std::pair<std::string, std::string>{"/nodes/rt/0/period_us",
                                              "must be an integer in [1, 9223372036854775807], not "
                                              "9223372036854775808"});
    doc["nodes"]["rt"][0]["period_us"] = json::parse("18446744073709551615");
    doc["seed"] = json::parse("18446744073709551615");
    const auto all = schemas().errors(doc, SchemaKind::Scenario);
    REQUIRE(all.size() == 1);
    CHECK(all[0].first == "/nodes/rt/0/period_us");
  }
  SECTION("beyond 2^64 - 1 or below -2^63: not a 64-bit integer") {
    doc["seed"] = json::parse("18446744073709551616");
    CHECK(error_of(doc) == std::pair<std::string, std::string>{
                               "/seed",
                               "must be an integer in [0, 18446744073709551615], not "
                               "1.8446744073709552e+19 (beyond the 64-bit integers)"});
    doc["seed"] = json::parse("-9223372036854775809");
    CHECK(error_of(doc).second ==
          "must be an integer in [0, 18446744073709551615], not "
          "-9.223372036854776e+18 (beyond the 64-bit integers)");
    doc["seed"] = -1;
    CHECK(error_of(doc).second == "must be in [0, 18446744073709551615], not -1");
  }
}

TEST_CASE("schema: further problems are counted after the first", "[schema]") {
  json doc = scenario();
  doc["nodes"]["rt"][0]["iterations"] = 0;
  doc["repetitions"] = 0;
  const auto [path, message] = error_of(doc);
  CHECK((path == "/nodes/rt/0/iterations" || path == "/repetitions"));
  CHECK_THAT(message, EndsWith(", not 0 (and 1 more problem)"));

  doc["seed"] = -1;
  doc["regulation"] = {{"threshold_pct", 0}};
  CHECK_THAT(error_of(doc).second, EndsWith(" (and 3 more problems)"));
}

TEST_CASE("schema: apply_defaults fills nested objects and array items", "[schema]") {
  SECTION("scenario") {
    json doc = scenario();
    doc["regulation"] = {{"metric", {{"line_bytes", 128}}}, {"threshold_pct", 30}};
    doc["nodes"].erase("nrt");
    schemas().apply_defaults(doc, SchemaKind::Scenario);
    const json& r = doc["regulation"];
    CHECK(r["policy"] == "interval");
    // Sampling and the periods default by policy (apply_policy_defaults, policy/rules.h), not
    // from the schema.
    CHECK_FALSE(r.contains("sampling"));
    CHECK_FALSE(r.contains("sampling_period_us"));
    CHECK_FALSE(r.contains("regulation_period_us"));
    CHECK(r["threshold_pct"] == 30);          // given values stay
    CHECK(r["metric"]["line_bytes"] == 128);  // given values stay, in nested objects too
    CHECK(r["metric"]["events"] == json({{"l2d_cache_refill", 1}, {"l2d_cache_wb", 1}}));
    CHECK(r["scope"] == "core");
    CHECK_FALSE(r.contains("reference_mbps"));  // no default: the platform's value
    CHECK(doc["nodes"]["nrt"] == json::array());
    CHECK(doc["nodes"]["rt"][0]["iterations"] == 1);
    CHECK_FALSE(doc["nodes"]["rt"][0].contains("period_us"));
    CHECK(doc["sim"] == json({{"quantum_us", 10}}));
    CHECK(doc["hw"] == json({{"pmc_source", "auto"},
                             {"adjacent_baselines", false},
                             {"max_repetitions", 20},
                             {"progress_timeout_ms", 60000},
                             {"scheduler", "fifo"},
                             {"throttle", "auto"},
                             {"watchdog_ms", 100},
                             {"transport", "inproc"},
                             {"dds", {{"namespace", ""}, {"signal_timeout_ms", 60000}}}}));
    CHECK(doc["nodes"]["rt"][0]["signal"] == "self");
    CHECK(doc["sweep"] == json::object());
    CHECK(doc["platform"] == "orin-agx");
    CHECK(doc["seed"] == 1);
    CHECK(doc["repetitions"] == 1);
    CHECK(doc["backend"] == "hw");

    // Idempotent, and the result is valid.
    json again = doc;
    schemas().apply_defaults(again, SchemaKind::Scenario);
    CHECK(again == doc);
    CHECK_FALSE(schemas().first_error(doc, SchemaKind::Scenario).has_value());
  }
  SECTION("an absent object gets its default and then the defaults inside it") {
    json doc = scenario();
    schemas().apply_defaults(doc, SchemaKind::Scenario);
    CHECK(doc["regulation"]["metric"]["line_bytes"] == 64);
    CHECK(doc["regulation"]["policy"] == "interval");
  }
  SECTION("workload: through $ref and into array items") {
    json w = workload();
    schemas().apply_defaults(w, SchemaKind::Workload);
    CHECK(w["sim"]["footprint_kb"] == 0);
    CHECK(w["sim"]["phases"][0]["mlp"] == 1);
    CHECK(w["hw"]["working_set_kb"] == 2048);
    CHECK(w["hw"]["passes"] == 1);
    CHECK_FALSE(w.contains("reference"));  // no default for an optional object without one
  }
}

TEST_CASE("schema: sim profiles are bounded to what can be simulated", "[schema]") {
  // Each of these passed before and then ran for many minutes (or forever).
  json w = workload();
  w["sim"]["instructions"] = 1e300;
  CHECK(error_of(w, SchemaKind::Workload).second == "must be in (0, 1000000000000], not 1e+300");
  w = workload();
  w["sim"]["phases"][0]["base_ipc"] = 1e-300;
  CHECK(error_of(w, SchemaKind::Workload).second == "must be in [0.01, 16], not 1e-300");
  w = workload();
  w["sim"]["phases"][0]["mlp"] = 1e300;
  CHECK(error_of(w, SchemaKind::Workload).second == "must be in [1, 64], not 1e+300");
  w = workload();
  w["sim"]["phases"][0]["l2_refill_pki"] = 1e300;
  CHECK(error_of(w, SchemaKind::Workload).second == "must be in [0, 1000], not 1e+300");
}

TEST_CASE("schema: names and sweep keys have a length limit", "[schema]") {
  json doc = scenario();
  doc["name"] = std::string(129, 'n');
  CHECK(error_of(doc) == std::pair<std::string, std::string>{
                             "/name", "must be at most 128 characters long, not 129"});
  doc = scenario();
  doc["sweep"] = {{std::string(1025, 'a'), {1}}};
  const auto [where, what] = error_of(doc);
  CHECK(where == "/sweep");
  CHECK_THAT(what, Catch::Matchers::Contains("key of 1025 characters is not valid here"));
}

TEST_CASE("schema: the policy enums name the registry's policies", "[schema]") {
  // A policy added to the registry (model/policy/policy.cpp) and not to the schema could never be
  // chosen; one in the schema and not in the registry would fail after validation.
  std::set<std::string> registered;
  for (const auto& info : builtin_policies())
    registered.insert(info.name);
  const auto enum_of = [](const std::string& file) {
    std::ifstream in(Home::locate().schemas() / file);
    const json schema = json::parse(in);
    const auto& e =
        schema.at("properties").at("regulation").at("properties").at("policy").at("enum");
    return e.get<std::set<std::string>>();
  };
  CHECK(enum_of("scenario.schema.json") == registered);
  // The guard runs every policy that regulates (with external sampling, docs/guard.md).
  registered.erase("none");
  CHECK(enum_of("guard.schema.json") == registered);
}

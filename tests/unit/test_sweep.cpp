// Sweep expansion: cartesian product in written order, stable ids, dotted paths with indexes.
#include <catch2/catch.hpp>

#include "scenario/sweep.h"

using namespace rosguard;
using json = nlohmann::json;

TEST_CASE("sweep paths parse keys and array indexes", "[sweep]") {
  const auto p = parse_sweep_path("nodes.rt[0].workload");
  REQUIRE(p.size() == 3);
  CHECK(p[0].key == "nodes");
  CHECK(p[1].key == "rt");
  CHECK(p[1].indexes == std::vector<std::size_t>{0});
  CHECK(p[2].key == "workload");
  CHECK(to_json_pointer(p) == "/nodes/rt/0/workload");
  CHECK_THROWS_AS(parse_sweep_path("regulation..policy"), InputError);
  CHECK_THROWS_AS(parse_sweep_path("nodes.rt[x]"), InputError);
  CHECK_THROWS_AS(parse_sweep_path(""), InputError);
}

TEST_CASE("set_at_path creates object keys but never array elements", "[sweep]") {
  json doc = {{"nodes", {{"rt", json::array({{{"workload", "mser"}}})}}}};
  set_at_path(doc, parse_sweep_path("nodes.rt[0].workload"), "sift");
  CHECK(doc["nodes"]["rt"][0]["workload"] == "sift");
  set_at_path(doc, parse_sweep_path("sim.quantum_us"), 5);
  CHECK(doc["sim"]["quantum_us"] == 5);
  CHECK_THROWS_AS(set_at_path(doc, parse_sweep_path("nodes.rt[1].workload"), "x"), InputError);
  CHECK_THROWS_AS(set_at_path(doc, parse_sweep_path("nodes.nrt[0].core"), 1), InputError);
}

TEST_CASE("the cartesian product runs in written key order, first key slowest", "[sweep]") {
  const json doc = {{"a", 0},
                    {"b", "x"},
                    {"sweep", {{"b", json::array({"p", "q", "r"})}, {"a", json::array({1, 2})}}}};
  const auto points = expand_sweep(doc, {"b", "a"});
  REQUIRE(points.size() == 6);
  const std::vector<std::pair<std::string, int>> expected = {{"p", 1}, {"p", 2}, {"q", 1},
                                                             {"q", 2}, {"r", 1}, {"r", 2}};
  for (std::size_t i = 0; i < points.size(); ++i) {
    CHECK(points[i].index == i);
    CHECK(points[i].document["b"] == expected[i].first);
    CHECK(points[i].document["a"] == expected[i].second);
    CHECK_FALSE(points[i].document.contains("sweep"));
    CHECK(points[i].params[0].value_index == i / 2);
  }
}

TEST_CASE("point ids depend on the parameter values only", "[sweep]") {
  const auto param = [](json value, std::size_t index) {
    return SweepParam{"regulation.threshold_pct", std::move(value), index,
                      "regulation.threshold_pct", 0};
  };
  const std::vector<SweepParam> p1 = {param(10, 0)};
  const std::vector<SweepParam> p2 = {param(20, 1)};
  CHECK(point_id(p1) == point_id({param(10, 7)}));
  CHECK(point_id(p1) != point_id(p2));
  CHECK(point_id(p1).size() == 11);
  CHECK(point_id(p1)[0] == 'p');
  // Stable across builds and machines: a fixed value pins the hash.
  CHECK(point_id({}) == "pe484222325");

  const json doc = {{"x", 1}, {"y", 2}, {"sweep", {{"x", {1, 2}}, {"y", {3}}}}};
  const auto a = expand_sweep(doc, {"x", "y"});
  json other = doc;
  other["z"] = "unrelated";
  const auto b = expand_sweep(other, {"x", "y"});
  for (std::size_t i = 0; i < a.size(); ++i)
    CHECK(a[i].id == b[i].id);
}

TEST_CASE("no sweep gives one point", "[sweep]") {
  const auto points = expand_sweep(json{{"a", 1}, {"sweep", json::object()}}, {});
  REQUIRE(points.size() == 1);
  CHECK(points[0].params.empty());
}

TEST_CASE("a key joining paths with + makes them co-vary", "[sweep]") {
  const json doc = {{"r", {{"s", 1}, {"p", 5}}},
                    {"t", 0},
                    {"sweep",
                     {{"r.s+r.p", json::array({json::array({1, 5}), json::array({2, 10})})},
                      {"t", json::array({7, 8, 9})}}}};
  CHECK(split_sweep_key("r.s+r.p") == std::vector<std::string>{"r.s", "r.p"});
  const auto points = expand_sweep(doc, {"r.s+r.p", "t"});
  REQUIRE(points.size() == 6);
  CHECK(points[0].document["r"] == json{{"s", 1}, {"p", 5}});
  CHECK(points[3].document["r"] == json{{"s", 2}, {"p", 10}});
  CHECK(points[3].document["t"] == 7);
  REQUIRE(points[3].params.size() == 3);
  CHECK(points[3].params[1].path == "r.p");
  CHECK(points[3].params[1].key == "r.s+r.p");
  CHECK(points[3].params[1].component == 1);
  CHECK(points[3].params[1].value_index == 1);
  // Same parameters, same id, whether they were swept jointly or not.
  const json separate = {
      {"r", {{"s", 1}, {"p", 5}}}, {"t", 0}, {"sweep", {{"r.s", {2}}, {"r.p", {10}}, {"t", {7}}}}};
  CHECK(expand_sweep(separate, {"r.s", "r.p", "t"})[0].id == points[3].id);

  json bad = doc;
  bad["sweep"]["r.s+r.p"] = json::array({json::array({1, 5}), 3});
  CHECK_THROWS_WITH(expand_sweep(bad, {"r.s+r.p", "t"}),
                    Catch::Contains("each value must be a list of 2 values (value 1 is not)"));
}

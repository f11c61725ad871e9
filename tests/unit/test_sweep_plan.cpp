// SweepPlan (model/scenario/sweep.h): counting points without building them, overflow, and
// building any one point on demand.
#include <catch2/catch.hpp>

#include "scenario/sweep.h"

using namespace rosguard;
using json = nlohmann::json;

namespace {

json doc_with(const json& sweep) {
  return json{{"a", 0}, {"b", 0}, {"list", json::array({1, 2})}, {"sweep", sweep}};
}

json values(int n) {
  json l = json::array();
  for (int i = 0; i < n; ++i)
    l.push_back(i);
  return l;
}

}  // namespace

TEST_CASE("SweepPlan counts points without building them", "[sweep]") {
  const json doc = doc_with({{"a", values(100000)}, {"b", values(100000)}});
  const SweepPlan plan(doc, {"a", "b"});
  CHECK(plan.count() == 10000000000ULL);
  CHECK(plan.sizes() == std::vector<std::uint64_t>{100000, 100000});
  const SweepPoint last = plan.point(plan.count() - 1);
  CHECK(last.document["a"] == 99999);
  CHECK(last.document["b"] == 99999);
  const SweepPoint p = plan.point(100000 * 7 + 3);  // the last key varies fastest
  CHECK(p.document["a"] == 7);
  CHECK(p.document["b"] == 3);
  CHECK(p.index == 700003);
}

TEST_CASE("SweepPlan refuses a product beyond 64 bits", "[sweep]") {
  json sweep = json::object();
  std::vector<std::string> order;
  for (int k = 0; k < 10; ++k) {  // 100^10 = 1e20 > 2^64
    const std::string key = "k" + std::to_string(k);
    sweep[key] = values(100);
    order.push_back(key);
  }
  const json doc = doc_with(sweep);
  try {
    SweepPlan plan(doc, order);
    FAIL("no error");
  } catch (const InputError& e) {
    CHECK(e.json_path() == "/sweep");
  }
  order.pop_back();
  json nine = doc;
  nine["sweep"].erase("k9");
  CHECK(SweepPlan(nine, order).count() == 1000000000000000000ULL);
}

TEST_CASE("SweepPlan names the key whose path is not in the point", "[sweep]") {
  const json doc = doc_with({{"list[5]", values(1)}});
  const SweepPlan plan(doc, {"list[5]"});
  try {
    plan.point(0);
    FAIL("no error");
  } catch (const SweepPathError& e) {
    CHECK(e.key() == "list[5]");
    CHECK(e.json_path() == "/sweep/list[5]");
    CHECK(e.file().empty());
  }
}

TEST_CASE("SweepPlan refuses a path swept by two keys, alone, joined or as a part", "[sweep]") {
  const auto refused = [](const json& sweep, const std::vector<std::string>& order) {
    try {
      SweepPlan plan(doc_with(sweep), order);
    } catch (const InputError& e) {
      return e.json_path() + ": " + e.message();
    }
    return std::string("accepted");
  };
  // A key swept alone and inside a joined key: duplicate points, or values dropped.
  CHECK_THAT(refused({{"a", values(2)}, {"b+a", json::array({json::array({1, 2})})}}, {"a", "b+a"}),
             Catch::Contains("/sweep/b+a: 'a' is swept by two keys ('a' and 'b+a')"));
  // A list and one of its elements.
  CHECK_THAT(refused({{"list", json::array({json::array()})}, {"list[1]", values(1)}},
                     {"list", "list[1]"}),
             Catch::Contains("/sweep/list[1]: 'list[1]' is swept by two keys"));
  CHECK(refused({{"a", values(2)}, {"b", values(2)}}, {"a", "b"}) == "accepted");
  CHECK(refused({{"list[0]", values(2)}, {"list[1]", values(2)}}, {"list[0]", "list[1]"}) ==
        "accepted");
}

TEST_CASE("expand_sweep builds the same points as SweepPlan", "[sweep]") {
  const json doc = doc_with({{"a", values(3)}, {"b", values(4)}});
  const auto points = expand_sweep(doc, {"a", "b"});
  const SweepPlan plan(doc, {"a", "b"});
  REQUIRE(points.size() == 12);
  for (std::size_t i = 0; i < points.size(); ++i)
    CHECK(points[i].id == plan.point(i).id);
}

TEST_CASE("SweepPlan refuses a value listed twice, naming the second", "[sweep]") {
  try {
    SweepPlan plan(doc_with({{"a", json::array({5, 10, 5.0})}}), {"a"});
    FAIL("no error");
  } catch (const InputError& e) {
    CHECK(e.json_path() == "/sweep/a/2");
    CHECK_THAT(e.message(), Catch::Contains("repeats value 0"));
  }
  try {
    SweepPlan plan(doc_with({{"a+b", json::array({json::array({1, 2}), json::array({1, 3}),
                                                  json::array({1, 2})})}}),
                   {"a+b"});
    FAIL("no error");
  } catch (const InputError& e) {
    CHECK(e.json_path() == "/sweep/a+b/2");
  }
  CHECK(SweepPlan(doc_with({{"a", json::array({5, 6})}}), {"a"}).count() == 2);
}

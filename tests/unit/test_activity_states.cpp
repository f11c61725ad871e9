// model/node/activity_states.h: an RT node's activity as state owned by its publishers.
#include <catch2/catch.hpp>

#include "node/activity_states.h"

using namespace rosguard;
using V = ActivityStates::Verdict;

TEST_CASE("activity: a true then a false from one publisher start and end the node", "[activity]") {
  ActivityStates a(2, 0);
  CHECK_FALSE(a.active(0));
  CHECK(a.set(0, "w1", true, 10) == V::Started);
  CHECK(a.active(0));
  CHECK_FALSE(a.active(1));
  CHECK(a.held_since(0, "w1") == 10);
  CHECK(a.set(0, "w1", false, 20) == V::Ended);
  CHECK_FALSE(a.active(0));
  CHECK(a.held_since(0, "w1") == -1);
}

TEST_CASE("activity: a repeated true and an unmatched false change nothing", "[activity]") {
  ActivityStates a(1, 0);
  CHECK(a.set(0, "w1", false, 5) == V::Unmatched);  // nothing held: ignored, never fatal
  CHECK_FALSE(a.active(0));
  CHECK(a.set(0, "w1", true, 10) == V::Started);
  CHECK(a.set(0, "w1", true, 11) == V::Duplicate);
  CHECK(a.held_since(0, "w1") == 10);  // the first true counts
  CHECK(a.set(0, "attacker", false, 12) == V::Unmatched);
  CHECK(a.active(0));  // another publisher's false cannot end w1's activation
  CHECK(a.set(0, "w1", false, 13) == V::Ended);
  CHECK(a.set(0, "w1", false, 14) == V::Unmatched);
}

TEST_CASE("activity: a node stays active until its last holder lets go", "[activity]") {
  ActivityStates a(1, 0);
  CHECK(a.set(0, "w1", true, 1) == V::Started);
  CHECK(a.set(0, "w2", true, 2) == V::Joined);
  CHECK(a.holders(0) == 2);
  CHECK(a.set(0, "w1", false, 3) == V::Left);
  CHECK(a.active(0));
  CHECK(a.set(0, "w2", false, 4) == V::Ended);
  CHECK_FALSE(a.active(0));
}

TEST_CASE("activity: a flood of alternating messages leaves the starts and ends paired",
          "[activity]") {
  ActivityStates a(1, 0);
  a.set(0, "rt", true, 0);  // the real RT job
  int starts = 1, ends = 0;
  for (int i = 0; i < 100000; ++i) {
    const auto v = a.set(0, i % 3 == 0 ? "rt" : "attacker", i % 2 == 0, i + 1);
    starts += v == V::Started;
    ends += v == V::Ended;
    CHECK((starts - ends == 0 || starts - ends == 1));
    REQUIRE(a.active(0) == (starts - ends == 1));
  }
}

TEST_CASE("activity: a publisher that is gone releases what it held", "[activity]") {
  ActivityStates a(3, 0);
  a.set(0, "w1", true, 1);
  a.set(1, "w1", true, 2);
  a.set(1, "w2", true, 3);
  a.set(2, "w2", true, 4);
  const auto r = a.gone("w1");
  REQUIRE(r.size() == 2);
  CHECK(r[0].rt == 0);
  CHECK(r[0].since == 1);
  CHECK(r[0].node_ended);
  CHECK(r[1].rt == 1);
  CHECK_FALSE(r[1].node_ended);  // w2 still holds node 1
  CHECK_FALSE(a.active(0));
  CHECK(a.active(1));
  CHECK(a.active(2));
  CHECK(a.gone("w1").empty());
  CHECK(a.gone("nobody").empty());
}

TEST_CASE("activity: an activation beyond the maximum is released, a shorter one is not",
          "[activity]") {
  ActivityStates a(2, 100);
  a.set(0, "w1", true, 0);
  a.set(1, "w2", true, 50);
  CHECK(a.expire(100).empty());  // exactly the maximum: still held
  const auto r = a.expire(101);
  REQUIRE(r.size() == 1);
  CHECK(r[0].rt == 0);
  CHECK(r[0].publisher == "w1");
  CHECK(r[0].node_ended);
  CHECK_FALSE(a.active(0));
  CHECK(a.active(1));
  CHECK(a.set(0, "w1", false, 120) == V::Unmatched);  // its late false is ignored
  CHECK(a.expire(151).size() == 1);
  ActivityStates unlimited(1, 0);
  unlimited.set(0, "w", true, 0);
  CHECK(unlimited.expire(1'000'000'000'000).empty());
}

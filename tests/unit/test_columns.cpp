// The column dictionary (model/results/columns.h) covers every column points.csv can have.
#include <catch2/catch.hpp>
#include <set>

#include "results/columns.h"
#include "results/results.h"

using namespace rosguard;

TEST_CASE("every points.csv column has a unit and a meaning", "[columns]") {
  for (const auto& header : {points_header(1, 1, {}), points_header(3, 4, {"regulation.x"})})
    for (const auto& name : header) {
      const auto info = describe_point_column(name);
      INFO(name);
      REQUIRE(info);
      CHECK(info->name == name);
      CHECK_FALSE(info->unit.empty());
      CHECK_FALSE(info->meaning.empty());
    }
}

TEST_CASE("the column dictionary: per-node patterns, no duplicates, MiB/s bandwidths",
          "[columns]") {
  const auto rt2 = describe_point_column("rt2_response_p99_us");
  REQUIRE(rt2);
  CHECK(rt2->unit == "us");
  CHECK(describe_point_column("nrt12_bandwidth_mbps")->unit == "MiB/s");
  CHECK(describe_point_column("nrt_bandwidth_mbps")->unit == "MiB/s");
  CHECK(describe_point_column("throttled_us")->unit == "us");
  CHECK(describe_point_column("param:nodes.rt[0].workload")->name == "param:nodes.rt[0].workload");
  CHECK_FALSE(describe_point_column("rt_nonsense"));
  CHECK_FALSE(describe_point_column("rtx_time_us"));
  CHECK(describe_point_column("nrt_throttle_count")->unit == "count");
  CHECK(describe_point_column("nrt2_name")->unit == "text");
  CHECK(describe_point_column("rt_core")->unit == "count");
  std::set<std::string> names;
  for (const auto& c : point_column_dictionary())
    CHECK(names.insert(c.name).second);
  for (const auto& c : sample_kind_dictionary())
    CHECK_FALSE(c.unit.empty());
}

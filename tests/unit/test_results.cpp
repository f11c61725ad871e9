// Results rows: the fixed columns of docs/design.md section 6, CSV quoting, medians.
#include <catch2/catch.hpp>
#include <cmath>

#include "results/results.h"

using namespace rosguard;

TEST_CASE("points.csv starts with the fixed columns in order", "[results]") {
  const auto& fixed = fixed_point_columns();
  const std::vector<std::string> expected = {"point",
                                             "rep",
                                             "backend",
                                             "rt_workload",
                                             "nrt_workload",
                                             "policy",
                                             "sampling",
                                             "scope",
                                             "threshold_pct",
                                             "sampling_period_us",
                                             "regulation_period_us",
                                             "rt_time_us",
                                             "rt_isolation_us",
                                             "rt_slowdown",
                                             "nrt_time_us",
                                             "nrt_isolation_us",
                                             "nrt_slowdown",
                                             "nrt_bandwidth_mbps",
                                             "throttle_count",
                                             "throttled_us",
                                             "activation_delay_p50_us",
                                             "activation_delay_max_us",
                                             "pmc_callback_p50_us",
                                             "rt_isolation_ipc",
                                             "rt_isolation_mbps",
                                             "nrt_isolation_ipc",
                                             "nrt_isolation_mbps"};
  CHECK(fixed == expected);
  const auto header = points_header(2, 1, {"regulation.threshold_pct"});
  CHECK(std::equal(expected.begin(), expected.end(), header.begin()));
  CHECK(std::find(header.begin(), header.end(), "rt1_slowdown") != header.end());
  CHECK(std::find(header.begin(), header.end(), "nrt1_slowdown") == header.end());
  CHECK(header.back() == "param:regulation.threshold_pct");
}

TEST_CASE("CSV fields are quoted only when needed and split back", "[results]") {
  CHECK(csv_escape("plain") == "plain");
  CHECK(csv_escape("a,b") == "\"a,b\"");
  CHECK(csv_escape("say \"hi\"") == "\"say \"\"hi\"\"\"");
  const auto cells = csv_split("x,\"a,b\",\"say \"\"hi\"\"\",");
  REQUIRE(cells.size() == 4);
  CHECK(cells[1] == "a,b");
  CHECK(cells[2] == "say \"hi\"");
  CHECK(cells[3].empty());
}

TEST_CASE("median and maximum of observations", "[results]") {
  CHECK(median({3, 1, 2}) == 2);
  CHECK(median({4, 1, 3, 2}) == 2.5);
  CHECK(std::isnan(median({})));
  CHECK(maximum({1, 5, 2}) == 5);
  CHECK(std::isnan(maximum({})));
}

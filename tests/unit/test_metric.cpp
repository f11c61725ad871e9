// The regulation metric: counter deltas (wrap-around, multiplex scaling), bytes from weighted
// events, Eq. 1 of the paper and budget sizes. Expected values are computed by hand.
#include <catch2/catch.hpp>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

#include "core/error.h"
#include "core/types.h"
#include "metric/metric.h"

using namespace rosguard;

namespace {
constexpr std::uint64_t kMax64 = std::numeric_limits<std::uint64_t>::max();
constexpr std::uint64_t k2to32 = std::uint64_t{1} << 32;
}  // namespace

TEST_CASE("wrap_delta: 64-bit counters, with and without a wrap", "[metric]") {
  CHECK(wrap_delta(10, 25, 64) == 15);
  CHECK(wrap_delta(7, 7, 64) == 0);
  CHECK(wrap_delta(kMax64 - 4, 5, 64) == 10);  // ..., max-4 -> max (4), -> 0 (5), -> 5 (10)
  CHECK(wrap_delta(kMax64, 0, 64) == 1);
  CHECK(wrap_delta(0, kMax64, 64) == kMax64);
}

TEST_CASE("wrap_delta: 32-bit counters wrap modulo 2^32", "[metric]") {
  CHECK(wrap_delta(100, 300, 32) == 200);
  CHECK(wrap_delta(0xFFFFFFF0u, 0x10u, 32) == 0x20u);
  CHECK(wrap_delta(k2to32 - 1, 0, 32) == 1);
  CHECK(wrap_delta(0, k2to32 - 1, 32) == k2to32 - 1);
  // Other widths (e.g. a 48-bit counter) follow the same rule.
  CHECK(wrap_delta((std::uint64_t{1} << 48) - 3, 2, 48) == 5);
}

TEST_CASE("scaled_delta: multiplexed counters are scaled by enabled / running", "[metric]") {
  SECTION("running < enabled: x enabled/running, over the interval between readings") {
    // The counter had always run (1 ms of 1 ms) before; in the last 2 us it ran 1 us of 2.
    const CounterValue prev{5000, 1'000'000, 1'000'000};
    const CounterValue cur{6000, 1'002'000, 1'001'000};
    CHECK(scaled_delta(prev, cur, 64) == 2000.0);
    // A quarter of the time: x4.
    CHECK(scaled_delta({0, 0, 0}, {1000, 4000, 1000}, 64) == 4000.0);
  }
  SECTION("running == 0: the raw increase, not a guess") {
    CHECK(scaled_delta({100, 1000, 500}, {100, 5000, 500}, 64) == 0.0);
    CHECK(scaled_delta({100, 1000, 500}, {350, 5000, 500}, 64) == 250.0);
  }
  SECTION("running == enabled: the raw increase") {
    CHECK(scaled_delta({100, 1000, 1000}, {350, 5000, 5000}, 64) == 250.0);
    CHECK(scaled_delta({100, 0, 0}, {350, 0, 0}, 64) == 250.0);
  }
  SECTION("wrap and scaling together") {
    CHECK(scaled_delta({0xFFFFFF00u, 0, 0}, {0x100u, 3000, 1000}, 32) == 0x200 * 3.0);
  }
}

TEST_CASE("Metric::delta_bytes: line size times the weighted sum of event deltas", "[metric]") {
  SECTION("default: L2 refills + L2 write-backs, 64-byte lines") {
    const Metric m(MetricSpec{});
    REQUIRE(m.event_count() == 2);
    CHECK(m.spec().events[0].name == "l2d_cache_refill");
    CHECK(m.spec().events[1].name == "l2d_cache_wb");
    const std::vector<CounterValue> prev{{1000, 0, 0}, {500, 0, 0}};
    const std::vector<CounterValue> cur{{1300, 10, 10}, {600, 10, 10}};
    CHECK(m.delta_bytes(prev, cur) == (300 + 100) * 64.0);
  }
  SECTION("weights and line size") {
    MetricSpec spec;
    spec.line_bytes = 128;
    spec.events = {{"a", 1.0}, {"b", 0.5}, {"c", 2.0}};
    const Metric m(spec);
    const std::vector<CounterValue> prev{{0, 0, 0}, {0, 0, 0}, {10, 0, 0}};
    const std::vector<CounterValue> cur{{100, 0, 0}, {40, 0, 0}, {13, 0, 0}};
    CHECK(m.delta_bytes(prev, cur) == (100 * 1.0 + 40 * 0.5 + 3 * 2.0) * 128);
  }
  SECTION("each event is scaled and wrapped on its own") {
    MetricSpec spec;
    spec.counter_bits = 32;
    const Metric m(spec);
    // Event 0 ran half the time; event 1 wrapped and ran all the time.
    const std::vector<CounterValue> prev{{0, 0, 0}, {k2to32 - 10, 0, 0}};
    const std::vector<CounterValue> cur{{100, 2000, 1000}, {10, 2000, 2000}};
    CHECK(m.delta_bytes(prev, cur) == (200 + 20) * 64.0);
  }
  SECTION("a counter group of the wrong size is rejected") {
    const Metric m(MetricSpec{});
    const std::vector<CounterValue> one(1), two(2), three(3);
    CHECK_THROWS_AS(m.delta_bytes(one, two), ContractError);
    CHECK_THROWS_AS(m.delta_bytes(two, three), ContractError);
  }
  SECTION("a metric needs events and a counter width in [1, 64]") {
    MetricSpec none;
    none.events.clear();
    CHECK_THROWS_AS(Metric(none), ContractError);
    MetricSpec zero;
    zero.counter_bits = 0;
    CHECK_THROWS_AS(Metric(zero), ContractError);
    MetricSpec wide;
    wide.counter_bits = 65;
    CHECK_THROWS_AS(Metric(wide), ContractError);
  }
}

TEST_CASE("eq1_mbps: Eq. 1 of the paper against Table 1's bandwidth_read", "[metric]") {
  // 26271.74 MB/s at 2201 MHz with 64-byte lines means, per cycle,
  //   l3_accesses / cycles = 26271.74 x 1024 x 1024 / (64 x 2201e6) = 0.195563920109...
  const double cycles = 2201e6;  // one second
  const double accesses = 0.19556392010904136 * cycles;
  CHECK(eq1_mbps(64, 2201e6, accesses, cycles) == Approx(26271.74).epsilon(1e-12));
  // Same ratio over a millisecond: same bandwidth.
  CHECK(eq1_mbps(64, 2201e6, accesses / 1000, cycles / 1000) == Approx(26271.74).epsilon(1e-12));
  // 1 MB/s: 1024 x 1024 bytes per second = 16384 lines at 64 B, over 1e9 cycles at 1 GHz.
  CHECK(eq1_mbps(64, 1e9, 16384, 1e9) == Approx(1.0).epsilon(1e-15));
  // Twice the line size, twice the bytes.
  CHECK(eq1_mbps(128, 1e9, 16384, 1e9) == Approx(2.0).epsilon(1e-15));
  CHECK(eq1_mbps(64, 2201e6, 1000, 0) == 0.0);
}

TEST_CASE("budget_bytes: threshold x reference x 1024 x 1024 B/s x length", "[metric]") {
  // 20 % of 1000 MB/s over 5 ms: 0.2 x 1000 x 1048576 x 0.005 = 1 048 576 B.
  CHECK(budget_bytes(20, 1000, 5 * kNsPerMs) == 1048576.0);
  // 100 % of 1 MB/s over one second: 1 048 576 B.
  CHECK(budget_bytes(100, 1, kNsPerS) == 1048576.0);
  // The paper's setpoint: 20 % of 26271.74 MB/s over 5 ms = 27 547 916.04224 B.
  CHECK(budget_bytes(20, 26271.74, 5 * kNsPerMs) == Approx(27547916.04224).epsilon(1e-12));
  // 30 % over 1 ms: 0.3 x 26271.74 x 1048576 x 0.001 = 8 264 374.812672 B.
  CHECK(budget_bytes(30, 26271.74, kNsPerMs) == Approx(8264374.812672).epsilon(1e-12));
  CHECK(budget_bytes(20, 1000, 0) == 0.0);
}

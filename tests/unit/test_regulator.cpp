// The regulator core, rule by rule (docs/design.md section 3.1, regulator/regulator.h). Every
// expected command sequence is written out by hand; budgets come from the formula
//   budget = threshold/100 x reference_mbps x 1024 x 1024 B/s x period,
// never from the code's own helper (see regulator_support.h for the reference setup).
#include <catch2/catch.hpp>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

#include "core/error.h"
#include "regulator_support.h"

using namespace rosguard;
using namespace rosguard::test;

// --- budgets -------------------------------------------------------------------------------

TEST_CASE("interval: budget scales with the regulation period", "[regulator][interval]") {
  SECTION("5 ms: 1 048 576 B (16 384 lines); at the budget is not over it, one line more is") {
    Rig rig(make_interval_policy(params(ms(5))), 1);
    rig.reg.rt_started(0, 0, rig.out);
    CHECK(rig.reg.accounts()[0].budget_bytes == 1048576.0);
    rig.sample(0, 0, 0);  // baseline
    rig.sample(ms(1), 0, 16384);
    CHECK(rig.reg.accounts()[0].used_bytes == 1048576.0);
    rig.sample(ms(2), 0, 1);
    CHECK(rig.out == Commands{{0, 0, On}, {ms(2), 0, Thr}});
  }
  SECTION("10 ms: twice the budget, 2 097 152 B (32 768 lines)") {
    Rig rig(make_interval_policy(params(ms(10))), 1);
    rig.reg.rt_started(0, 0, rig.out);
    CHECK(rig.reg.accounts()[0].budget_bytes == 2097152.0);
    rig.sample(0, 0, 0);
    rig.sample(ms(1), 0, 16385);  // over a 5 ms budget, not over a 10 ms one
    rig.sample(ms(2), 0, 16383);  // 32 768 lines: exactly the budget
    CHECK(rig.out == Commands{{0, 0, On}});
    rig.sample(ms(3), 0, 1);
    CHECK(rig.out == Commands{{0, 0, On}, {ms(3), 0, Thr}});
  }
  SECTION("1 ms: a fifth of the 5 ms budget, 209 715.2 B") {
    Rig rig(make_interval_policy(params(ms(1))), 1);
    rig.reg.rt_started(0, 0, rig.out);
    CHECK(rig.reg.accounts()[0].budget_bytes == Approx(209715.2).epsilon(1e-12));
    rig.sample(0, 0, 0);
    rig.sample(us(500), 0, 3276);  // 209 664 B
    CHECK(rig.out == Commands{{0, 0, On}});
    rig.sample(us(600), 0, 1);  // 209 728 B
    CHECK(rig.out == Commands{{0, 0, On}, {us(600), 0, Thr}});
  }
  SECTION("the threshold scales the budget too: 10 % of 1000 MB/s over 5 ms is 524 288 B") {
    Rig rig(make_interval_policy(params(ms(5), 0, 10.0)), 1);
    rig.reg.rt_started(0, 0, rig.out);
    CHECK(rig.reg.accounts()[0].budget_bytes == 524288.0);
  }
}

TEST_CASE("interval: exceedance is detected at the first sample that crosses the budget",
          "[regulator][interval]") {
  Rig rig(make_interval_policy(params()), 1);
  rig.reg.rt_started(0, 0, rig.out);
  rig.sample(0, 0, 0);
  rig.sample(ms(1), 0, 5000);  //  5 000 lines
  rig.sample(ms(2), 0, 5000);  // 10 000
  rig.sample(ms(3), 0, 5000);  // 15 000 < 16 384
  CHECK(rig.out == Commands{{0, 0, On}});
  rig.sample(ms(4), 0, 5000);  // 20 000 > 16 384
  CHECK(rig.out == Commands{{0, 0, On}, {ms(4), 0, Thr}});
  CHECK(rig.reg.accounts()[0].used_bytes == 20000.0 * 64);
  CHECK(rig.reg.accounts()[0].throttled);
  CHECK(rig.reg.entity(0).state == NodeState::Thr);
  CHECK(rig.reg.entity(0).throttles == 1);
}

TEST_CASE("interval: every event of the metric counts towards the budget",
          "[regulator][interval]") {
  // Refills alone stay under the budget; refills plus write-backs cross it.
  Rig rig(make_interval_policy(params()), 1);
  rig.reg.rt_started(0, 0, rig.out);
  rig.sample(0, 0, 0);
  auto c = rig.counters[0];
  c[0] = {10000, static_cast<std::uint64_t>(ms(1)), static_cast<std::uint64_t>(ms(1))};
  c[1] = {6384, static_cast<std::uint64_t>(ms(1)), static_cast<std::uint64_t>(ms(1))};
  rig.reg.sample(ms(1), 0, c, rig.out);  // 16 384 lines: at the budget
  CHECK(rig.out == Commands{{0, 0, On}});
  c[1].value += 1;
  c[0].time_enabled_ns = c[0].time_running_ns = c[1].time_enabled_ns = c[1].time_running_ns =
      static_cast<std::uint64_t>(ms(2));
  rig.reg.sample(ms(2), 0, c, rig.out);
  CHECK(rig.out == Commands{{0, 0, On}, {ms(2), 0, Thr}});
}

// --- replenishment and windows -------------------------------------------------------------

TEST_CASE("interval: the budget is replenished at each boundary", "[regulator][interval]") {
  Rig rig(make_interval_policy(params()), 1);
  rig.reg.rt_started(0, 0, rig.out);
  rig.sample(0, 0, 0);
  rig.sample(ms(1), 0, 20000);
  rig.reg.tick(ms(5), rig.out);
  CHECK(rig.reg.accounts()[0].used_bytes == 0.0);
  CHECK(rig.reg.accounts()[0].window == 1);
  CHECK(rig.reg.accounts()[0].window_start == ms(5));
  CHECK_FALSE(rig.reg.accounts()[0].throttled);
  CHECK(rig.reg.entity(0).state == NodeState::On);

  rig.sample(ms(5), 0, 0);      // the node's first sample after the throttle ends
  rig.sample(ms(6), 0, 20000);  // a fresh budget, exhausted again
  rig.reg.tick(ms(10), rig.out);
  rig.sample(ms(10), 0, 0);
  rig.sample(ms(11), 0, 100);
  rig.reg.tick(ms(15), rig.out);  // not throttled: nothing to replenish
  CHECK(rig.out ==
        Commands{{0, 0, On}, {ms(1), 0, Thr}, {ms(5), 0, Rep}, {ms(6), 0, Thr}, {ms(10), 0, Rep}});
  CHECK(rig.reg.accounts()[0].window == 3);
  CHECK(rig.reg.next_tick() == ms(20));
}

TEST_CASE("interval: no repeated THR to an entity already throttled", "[regulator][interval]") {
  // External sampling keeps reading a throttled core; its usage grows but THR is sent once.
  Rig rig(make_interval_policy(params()), 1);
  rig.reg.rt_started(0, 0, rig.out);
  rig.sample(0, 0, 0);
  rig.sample(ms(1), 0, 20000);
  rig.sample(ms(2), 0, 20000);
  rig.sample(ms(3), 0, 50000);
  CHECK(rig.out == Commands{{0, 0, On}, {ms(1), 0, Thr}});
  CHECK(rig.reg.entity(0).throttles == 1);
  CHECK(rig.reg.accounts()[0].used_bytes == 90000.0 * 64);

  // One THR per window: the next window may throttle again.
  rig.reg.tick(ms(5), rig.out);
  rig.sample(ms(5), 0, 0);
  rig.sample(ms(6), 0, 20000);
  rig.sample(ms(7), 0, 20000);
  CHECK(rig.out == Commands{{0, 0, On}, {ms(1), 0, Thr}, {ms(5), 0, Rep}, {ms(6), 0, Thr}});
  CHECK(rig.reg.entity(0).throttles == 2);
}

TEST_CASE("interval: the first sample of an activation is a baseline and gives no usage",
          "[regulator][interval]") {
  Rig rig(make_interval_policy(params()), 1);
  rig.counters[0][0].value = 1'000'000'000;  // counted before the activation: not usage
  rig.reg.rt_started(0, 0, rig.out);
  rig.sample(ms(1), 0, 0);
  CHECK(rig.reg.accounts()[0].used_bytes == 0.0);
  CHECK(rig.reg.entity(0).bytes_active == 0.0);
  rig.sample(ms(2), 0, 16384);  // exactly the budget: only true if the baseline counted nothing
  CHECK(rig.reg.entity(0).bytes_active == 16384.0 * 64);
  CHECK(rig.out == Commands{{0, 0, On}});
  rig.sample(ms(3), 0, 1);
  CHECK(rig.out == Commands{{0, 0, On}, {ms(3), 0, Thr}});

  // A new activation takes a new baseline, whatever the counters did in between.
  rig.reg.rt_finished(ms(4), 0, rig.out);
  rig.sample(ms(6), 0, 500'000);  // inactive: ignored
  rig.counters[0][0].value += 7'000'000;
  rig.reg.rt_started(ms(10), 0, rig.out);
  rig.sample(ms(10), 0, 0);
  rig.sample(ms(11), 0, 16384);
  CHECK(rig.reg.accounts()[0].used_bytes == 1048576.0);
  CHECK(rig.reg.entity(0).bytes_active == 1048576.0);
  CHECK(rig.out == Commands{{0, 0, On}, {ms(3), 0, Thr}, {ms(4), 0, Off}, {ms(10), 0, On}});
}

TEST_CASE("interval: usage straddling a window boundary counts only its share after it",
          "[regulator][interval]") {
  // Baseline at 3 ms, boundary at 5 ms, sample at 7 ms: half the time the sample covers lies in
  // the new window, so half its lines count against it.
  Rig rig(make_interval_policy(params()), 1);
  rig.reg.rt_started(0, 0, rig.out);
  rig.sample(ms(3), 0, 0);
  rig.reg.tick(ms(5), rig.out);

  SECTION("20 000 lines over 3-7 ms: 10 000 after the boundary, under the budget") {
    rig.sample(ms(7), 0, 20000);
    CHECK(rig.reg.accounts()[0].used_bytes == 10000.0 * 64);
    CHECK(rig.out == Commands{{0, 0, On}});
  }
  SECTION("40 000 lines over 3-7 ms: 20 000 after the boundary, over the budget") {
    rig.sample(ms(7), 0, 40000);
    CHECK(rig.reg.accounts()[0].used_bytes == 20000.0 * 64);
    CHECK(rig.out == Commands{{0, 0, On}, {ms(7), 0, Thr}});
  }
  SECTION("unequal shares: 30 000 lines over 3-8 ms, 3/5 of them after the boundary") {
    rig.sample(ms(8), 0, 30000);
    CHECK(rig.reg.accounts()[0].used_bytes == Approx(18000.0 * 64).epsilon(1e-12));
    CHECK(rig.out == Commands{{0, 0, On}, {ms(8), 0, Thr}});
  }
}

TEST_CASE("interval: a sample taken at a boundary belongs wholly to the closed window",
          "[regulator][interval]") {
  Rig rig(make_interval_policy(params()), 1);
  rig.reg.rt_started(0, 0, rig.out);
  rig.sample(ms(4), 0, 0);
  rig.sample(ms(5), 0, 1'000'000);  // covers 4-5 ms: nothing of it lies after 5 ms
  CHECK(rig.reg.accounts()[0].window == 1);
  CHECK(rig.reg.accounts()[0].used_bytes == 0.0);
  rig.sample(ms(6), 0, 16384);  // covers 5-6 ms only: wholly in the new window
  CHECK(rig.reg.accounts()[0].used_bytes == 1048576.0);
  CHECK(rig.out == Commands{{0, 0, On}});
}

TEST_CASE("interval: several missed boundaries are caught up in one call",
          "[regulator][interval]") {
  Rig rig(make_interval_policy(params()), 1);
  rig.reg.rt_started(0, 0, rig.out);
  rig.sample(0, 0, 0);
  rig.sample(ms(2), 0, 20000);
  REQUIRE(rig.reg.next_tick() == ms(5));

  SECTION("by a sample: one REPLENISH, the window holding t counts") {
    // Boundaries at 5, 10 and 15 ms were not ticked. 30 000 lines over 2-17 ms: 2/15 of them
    // (4 000 lines) lie in the window that opened at 15 ms.
    rig.sample(ms(17), 0, 30000);
    CHECK(rig.out == Commands{{0, 0, On}, {ms(2), 0, Thr}, {ms(17), 0, Rep}});
    CHECK(rig.reg.accounts()[0].window == 3);
    CHECK(rig.reg.accounts()[0].window_start == ms(15));
    CHECK(rig.reg.accounts()[0].used_bytes == Approx(4000.0 * 64).epsilon(1e-12));
    CHECK(rig.reg.next_tick() == ms(20));
  }
  SECTION("by a late tick") {
    rig.reg.tick(ms(12), rig.out);
    CHECK(rig.out == Commands{{0, 0, On}, {ms(2), 0, Thr}, {ms(12), 0, Rep}});
    CHECK(rig.reg.accounts()[0].window == 2);
    CHECK(rig.reg.accounts()[0].window_start == ms(10));
    CHECK(rig.reg.next_tick() == ms(15));
  }
  SECTION("by a late tick exactly on a boundary") {
    rig.reg.tick(ms(15), rig.out);
    CHECK(rig.reg.accounts()[0].window == 3);
    CHECK(rig.reg.accounts()[0].window_start == ms(15));
    CHECK(rig.reg.next_tick() == ms(20));
  }
}

TEST_CASE("interval: tick() and sample() at the same t give the same commands in either order",
          "[regulator][interval]") {
  // Window 0 holds 10 000 lines; at 5 ms a sample brings 10 000 more. Were the sample accounted
  // before the boundary, the entity would get THR at 5 ms (and REPLENISH at once).
  const auto run = [](bool tick_first, bool throttle_first) {
    Rig rig(make_interval_policy(params()), 2);
    rig.reg.rt_started(0, 0, rig.out);
    rig.sample(0, 0, 0);
    rig.sample(0, 1, 0);
    rig.sample(ms(4), 0, 10000);
    if (throttle_first) rig.sample(ms(4), 1, 20000);
    if (tick_first) rig.reg.tick(ms(5), rig.out);
    rig.sample(ms(5), 0, 10000);
    rig.sample(ms(5), 1, 0);
    if (!tick_first) rig.reg.tick(ms(5), rig.out);
    rig.sample(ms(6), 0, 10000);
    return std::pair{rig.out, rig.reg.accounts()[0].used_bytes};
  };
  SECTION("nothing throttled") {
    const auto a = run(true, false);
    const auto b = run(false, false);
    CHECK(a.first == Commands{{0, 0, On}, {0, 1, On}});
    CHECK(a.first == b.first);
    CHECK(a.second == 10000.0 * 64);
    CHECK(a.second == b.second);
  }
  SECTION("one entity throttled") {
    const auto a = run(true, true);
    const auto b = run(false, true);
    CHECK(a.first == Commands{{0, 0, On}, {0, 1, On}, {ms(4), 1, Thr}, {ms(5), 1, Rep}});
    CHECK(a.first == b.first);
    CHECK(a.second == b.second);
  }
}

TEST_CASE("interval: usage is charged by when it was measured, not when it arrives",
          "[regulator][interval]") {
  // Read at 4.9 ms (before the 5 ms boundary), processed at 5.1 ms: all its lines occurred in
  // the closed window, none is charged to the window that opened at 5 ms.
  Rig rig(make_interval_policy(params()), 1);
  rig.reg.rt_started(0, 0, rig.out);
  rig.sample(ms(4), 0, 0);
  auto& c = rig.counters[0];
  c[0].value += 20000;
  rig.reg.sample(us(5100), 0, c, rig.out, us(4900));
  CHECK(rig.reg.accounts()[0].window == 1);
  CHECK(rig.reg.accounts()[0].used_bytes == 0.0);
  CHECK(rig.reg.entity(0).bytes_active == 20000.0 * 64);
  // The next reading, at 6 ms, covers 4.9-6 ms: 1/1.1 of it lies after the boundary.
  c[0].value += 11000;
  rig.reg.sample(ms(6), 0, c, rig.out, ms(6));
  CHECK(rig.reg.accounts()[0].used_bytes == Approx(10000.0 * 64).epsilon(1e-12));
  CHECK(rig.out == Commands{{0, 0, On}});
}

TEST_CASE("regulator: measurement times must be consistent", "[regulator][errors]") {
  Rig rig(make_interval_policy(params()), 1);
  rig.reg.rt_started(0, 0, rig.out);
  rig.sample(ms(2), 0, 0);
  const auto& c = rig.counters[0];
  CHECK_THROWS_AS(rig.reg.sample(ms(3), 0, c, rig.out, ms(4)), ContractError);  // future
  CHECK_THROWS_AS(rig.reg.sample(ms(3), 0, c, rig.out, ms(1)), ContractError);  // older
  CHECK_NOTHROW(rig.reg.sample(ms(3), 0, c, rig.out, ms(2)));  // same instant again is fine
}

TEST_CASE("interval: next_tick() is the next window boundary while active, else none",
          "[regulator][interval]") {
  Rig rig(make_interval_policy(params()), 1);
  CHECK_FALSE(rig.reg.next_tick().has_value());
  rig.reg.rt_started(ms(2), 0, rig.out);  // windows start at the activation, not at 0
  CHECK(rig.reg.next_tick() == ms(7));
  rig.reg.tick(ms(7), rig.out);
  CHECK(rig.reg.next_tick() == ms(12));
  rig.sample(ms(9), 0, 0);  // inputs between boundaries leave it alone
  CHECK(rig.reg.next_tick() == ms(12));
  rig.reg.tick(ms(12), rig.out);
  CHECK(rig.reg.next_tick() == ms(17));
  rig.reg.rt_finished(ms(13), 0, rig.out);
  CHECK_FALSE(rig.reg.next_tick().has_value());
  rig.reg.rt_started(ms(21), 0, rig.out);  // a new activation starts its own windows
  CHECK(rig.reg.next_tick() == ms(26));
  CHECK(rig.reg.accounts()[0].window == 0);
  CHECK(rig.reg.accounts()[0].window_start == ms(21));
}

// --- activation ----------------------------------------------------------------------------

TEST_CASE("activation: ON to every entity at the first RT start, OFF when the last RT finishes",
          "[regulator][activation]") {
  Rig rig(make_interval_policy(params()), 3, Scope::Core, 2);
  CHECK_FALSE(rig.reg.active());
  rig.reg.rt_started(ms(1), 0, rig.out);
  CHECK(rig.out == Commands{{ms(1), 0, On}, {ms(1), 1, On}, {ms(1), 2, On}});
  CHECK(rig.reg.active());
  rig.reg.rt_started(ms(2), 1, rig.out);   // a second concurrent RT node: nothing
  rig.reg.rt_finished(ms(3), 0, rig.out);  // one RT node still runs: nothing
  CHECK(rig.out.size() == 3);
  CHECK(rig.reg.active());
  rig.reg.rt_finished(ms(4), 1, rig.out);
  CHECK(rig.out == Commands{{ms(1), 0, On},
                            {ms(1), 1, On},
                            {ms(1), 2, On},
                            {ms(4), 0, Off},
                            {ms(4), 1, Off},
                            {ms(4), 2, Off}});
  CHECK_FALSE(rig.reg.active());
  for (std::size_t e = 0; e < 3; ++e)
    CHECK(rig.reg.entity(e).state == NodeState::Off);

  // Regulation restarts with the next RT start, whichever RT node it is.
  rig.reg.rt_started(ms(6), 1, rig.out);
  CHECK(rig.out.size() == 9);
  CHECK(rig.out.back() == CommandOut{ms(6), 2, On});
}

TEST_CASE("activation: OFF on finish also releases throttled entities - inactive is silent",
          "[regulator][activation]") {
  Rig rig(make_interval_policy(params()), 2);
  rig.reg.rt_started(0, 0, rig.out);
  rig.sample(0, 0, 0);
  rig.sample(0, 1, 0);
  rig.sample(ms(1), 1, 20000);
  rig.reg.rt_finished(ms(2), 0, rig.out);
  const Commands expected{
      {0, 0, On}, {0, 1, On}, {ms(1), 1, Thr}, {ms(2), 0, Off}, {ms(2), 1, Off}};
  CHECK(rig.out == expected);
  CHECK(rig.reg.entity(1).state == NodeState::Off);

  // While inactive: no boundaries, no accounting, no commands.
  CHECK_FALSE(rig.reg.next_tick().has_value());
  rig.sample(ms(3), 0, 1'000'000);
  rig.sample(ms(4), 0, 1'000'000);
  rig.reg.tick(ms(5), rig.out);
  rig.reg.tick(ms(50), rig.out);
  CHECK(rig.out == expected);
}

// --- policies ------------------------------------------------------------------------------

TEST_CASE("monolithic: throttled until the last RT node finishes", "[regulator][monolithic]") {
  // One budget for the activation: 20 % of 1000 MB/s over a 10 ms RT isolation time is
  // 2 097 152 B (32 768 lines). The 5 ms regulation period plays no part.
  Rig rig(make_monolithic_policy(params(ms(5), ms(10))), 1, Scope::Core, 2);
  rig.reg.rt_started(0, 0, rig.out);
  rig.sample(0, 0, 0);
  rig.reg.rt_started(ms(1), 1, rig.out);
  CHECK(rig.reg.accounts()[0].budget_bytes == 2097152.0);
  CHECK_FALSE(rig.reg.next_tick().has_value());
  rig.sample(ms(4), 0, 20000);  // over a 5 ms interval budget, under the monolithic one
  rig.reg.tick(ms(5), rig.out);
  rig.sample(ms(14), 0, 20000);  // 40 000 lines in the activation: over
  CHECK(rig.out == Commands{{0, 0, On}, {ms(14), 0, Thr}});

  rig.sample(ms(15), 0, 0);
  rig.reg.rt_finished(ms(16), 0, rig.out);  // rt1 still runs: stays throttled
  rig.reg.tick(ms(20), rig.out);
  rig.reg.tick(ms(25), rig.out);
  rig.sample(ms(26), 0, 100);
  CHECK(rig.out == Commands{{0, 0, On}, {ms(14), 0, Thr}});
  CHECK(rig.reg.entity(0).state == NodeState::Thr);
  rig.reg.rt_finished(ms(30), 1, rig.out);
  CHECK(rig.out == Commands{{0, 0, On}, {ms(14), 0, Thr}, {ms(30), 0, Off}});

  // The next activation has a fresh budget.
  rig.reg.rt_started(ms(40), 0, rig.out);
  rig.sample(ms(40), 0, 0);
  rig.sample(ms(41), 0, 32768);
  CHECK(rig.out.back() == CommandOut{ms(40), 0, On});
  rig.sample(ms(42), 0, 1);
  CHECK(rig.out.back() == CommandOut{ms(42), 0, Thr});
}

TEST_CASE("monitor: switches entities ON and OFF but never throttles", "[regulator][monitor]") {
  Rig rig(make_monitor_policy(params()), 2);
  rig.reg.rt_started(0, 0, rig.out);
  rig.sample(0, 0, 0);
  rig.sample(0, 1, 0);
  rig.sample(ms(1), 0, 100 * kBudgetLines);  // a hundred budgets
  CHECK(rig.reg.accounts()[0].used_bytes == 100 * kBudgetBytes);
  CHECK(rig.reg.next_tick() == ms(5));
  rig.reg.tick(ms(5), rig.out);
  CHECK(rig.reg.accounts()[0].used_bytes == 0.0);  // still accounted per period
  rig.sample(ms(6), 0, 1'000'000);
  rig.sample(ms(7), 1, 1'000'000);
  rig.reg.tick(ms(10), rig.out);
  rig.reg.rt_finished(ms(12), 0, rig.out);
  CHECK(rig.out == Commands{{0, 0, On}, {0, 1, On}, {ms(12), 0, Off}, {ms(12), 1, Off}});
  CHECK(rig.reg.entity(0).throttles == 0);
}

TEST_CASE("none: the regulator emits nothing at all", "[regulator][none]") {
  Rig rig(make_none_policy(params()), 2, Scope::Core, 2);
  rig.reg.rt_started(0, 0, rig.out);
  rig.reg.rt_started(ms(1), 1, rig.out);
  CHECK_FALSE(rig.reg.next_tick().has_value());
  rig.sample(ms(1), 0, 0);
  rig.sample(ms(2), 0, 1'000'000);
  rig.sample(ms(3), 1, 1'000'000);
  rig.reg.tick(ms(5), rig.out);
  rig.reg.rt_finished(ms(6), 0, rig.out);
  rig.reg.rt_finished(ms(7), 1, rig.out);
  rig.reg.rt_started(ms(8), 0, rig.out);
  CHECK(rig.out.empty());
  CHECK(rig.reg.entity(0).state == NodeState::Off);
  CHECK(rig.reg.entity(0).bytes_active == 0.0);
  CHECK(rig.reg.accounts()[0].used_bytes == 0.0);
}

// --- scope ---------------------------------------------------------------------------------

TEST_CASE("group scope: one shared budget - exhausting it throttles every ON member",
          "[regulator][scope]") {
  SECTION("one member alone exhausts it") {
    Rig rig(make_interval_policy(params()), 3, Scope::Group);
    REQUIRE(rig.reg.accounts().size() == 1);
    rig.reg.rt_started(0, 0, rig.out);
    for (std::size_t e = 0; e < 3; ++e)
      rig.sample(0, e, 0);
    rig.sample(ms(1), 2, kBudgetLines + 1);
    CHECK(
        rig.out ==
        Commands{
            {0, 0, On}, {0, 1, On}, {0, 2, On}, {ms(1), 0, Thr}, {ms(1), 1, Thr}, {ms(1), 2, Thr}});
    rig.sample(ms(2), 0, 1000);  // no second round of THR
    rig.reg.tick(ms(5), rig.out);
    CHECK(rig.out.size() == 9);
    CHECK(rig.out[6] == CommandOut{ms(5), 0, Rep});
    CHECK(rig.out[7] == CommandOut{ms(5), 1, Rep});
    CHECK(rig.out[8] == CommandOut{ms(5), 2, Rep});
  }
  SECTION("two members each under the budget exceed it together") {
    const auto run = [](Scope scope) {
      Rig rig(make_interval_policy(params()), 3, scope);
      rig.reg.rt_started(0, 0, rig.out);
      for (std::size_t e = 0; e < 3; ++e)
        rig.sample(0, e, 0);
      rig.sample(ms(1), 0, 10000);
      rig.sample(ms(2), 1, 10000);
      return rig.out;
    };
    CHECK(
        run(Scope::Group) ==
        Commands{
            {0, 0, On}, {0, 1, On}, {0, 2, On}, {ms(2), 0, Thr}, {ms(2), 1, Thr}, {ms(2), 2, Thr}});
    CHECK(run(Scope::Core) == Commands{{0, 0, On}, {0, 1, On}, {0, 2, On}});
    CHECK(run(Scope::Node) == Commands{{0, 0, On}, {0, 1, On}, {0, 2, On}});
  }
}

TEST_CASE("core scope: REPLENISH goes only to throttled entities", "[regulator][scope]") {
  Rig rig(make_interval_policy(params()), 3);
  REQUIRE(rig.reg.accounts().size() == 3);
  rig.reg.rt_started(0, 0, rig.out);
  for (std::size_t e = 0; e < 3; ++e)
    rig.sample(0, e, 0);
  rig.sample(ms(1), 0, 10000);
  rig.sample(ms(1), 1, 20000);
  rig.sample(ms(1), 2, 16384);
  rig.reg.tick(ms(5), rig.out);
  CHECK(rig.out == Commands{{0, 0, On}, {0, 1, On}, {0, 2, On}, {ms(1), 1, Thr}, {ms(5), 1, Rep}});
  CHECK(rig.reg.entity(0).account == 0);
  CHECK(rig.reg.entity(2).account == 2);
}

TEST_CASE("accounts_for_scope: one account per entity for core and node, one for group",
          "[regulator][scope]") {
  CHECK(accounts_for_scope(Scope::Core, 3) == std::vector<std::size_t>{0, 1, 2});
  CHECK(accounts_for_scope(Scope::Node, 3) == std::vector<std::size_t>{0, 1, 2});
  CHECK(accounts_for_scope(Scope::Group, 3) == std::vector<std::size_t>{0, 0, 0});
  CHECK(accounts_for_scope(Scope::Group, 0).empty());
}

// --- counters ------------------------------------------------------------------------------

TEST_CASE("regulator: 32-bit counters that wrap give their true increase", "[regulator][metric]") {
  MetricSpec spec;
  spec.counter_bits = 32;
  Rig rig(make_interval_policy(params()), 1, Scope::Core, 1, spec);
  rig.counters[0][0].value = (std::uint64_t{1} << 32) - 1000;
  rig.reg.rt_started(0, 0, rig.out);
  rig.sample(0, 0, 0);
  rig.counters[0][0].value = 16384 - 1000;  // wrapped: 16 384 lines later
  rig.sample(ms(1), 0, 0);
  CHECK(rig.reg.accounts()[0].used_bytes == 1048576.0);
  CHECK(rig.out == Commands{{0, 0, On}});
  rig.sample(ms(2), 0, 1);
  CHECK(rig.out == Commands{{0, 0, On}, {ms(2), 0, Thr}});
}

TEST_CASE("regulator: multiplexed counters are scaled by enabled / running time",
          "[regulator][metric]") {
  // Both events ran half of the time between readings: 8 192 raw lines stand for 16 384.
  Rig rig(make_interval_policy(params()), 1);
  rig.reg.rt_started(0, 0, rig.out);
  const auto read = [&](TimeNs t, std::uint64_t refill, std::uint64_t running_ns) {
    std::vector<CounterValue> c(2);
    c[0] = {refill, static_cast<std::uint64_t>(t), running_ns};
    c[1] = {0, static_cast<std::uint64_t>(t), running_ns};
    rig.reg.sample(t, 0, c, rig.out);
  };
  read(0, 0, 0);
  read(ms(1), 8192, static_cast<std::uint64_t>(us(500)));
  CHECK(rig.reg.accounts()[0].used_bytes == 1048576.0);
  CHECK(rig.out == Commands{{0, 0, On}});
  read(ms(2), 8193, static_cast<std::uint64_t>(us(1000)));  // 1 raw line, x2
  CHECK(rig.reg.accounts()[0].used_bytes == 1048576.0 + 128.0);
  CHECK(rig.out == Commands{{0, 0, On}, {ms(2), 0, Thr}});
}

// --- contract violations -------------------------------------------------------------------

TEST_CASE("regulator: contract violations throw", "[regulator][errors]") {
  Rig rig(make_interval_policy(params()), 2, Scope::Core, 2);
  rig.reg.rt_started(ms(2), 0, rig.out);

  SECTION("time going backwards") {
    CHECK_THROWS_AS(rig.reg.tick(ms(1), rig.out), ContractError);
    CHECK_THROWS_AS(rig.reg.rt_started(ms(1), 1, rig.out), ContractError);
    CHECK_THROWS_AS(rig.reg.rt_finished(ms(1), 0, rig.out), ContractError);
    CHECK_THROWS_AS(rig.sample(ms(1), 0, 0), ContractError);
    rig.reg.tick(ms(2), rig.out);  // the same t is fine
  }
  SECTION("wrong number of counters") {
    std::vector<CounterValue> three(3), one(1);
    CHECK_THROWS_AS(rig.reg.sample(ms(3), 0, three, rig.out), ContractError);
    CHECK_THROWS_AS(rig.reg.sample(ms(3), 0, one, rig.out), ContractError);
  }
  SECTION("unknown RT node or entity") {
    CHECK_THROWS_AS(rig.reg.rt_started(ms(3), 2, rig.out), ContractError);
    CHECK_THROWS_AS(rig.reg.rt_finished(ms(3), 2, rig.out), ContractError);
    CHECK_THROWS_AS(rig.reg.sample(ms(3), 2, rig.counters[0], rig.out), ContractError);
  }
  SECTION("an RT node started twice, or finished without running") {
    CHECK_THROWS_AS(rig.reg.rt_started(ms(3), 0, rig.out), ContractError);
    CHECK_THROWS_AS(rig.reg.rt_finished(ms(3), 1, rig.out), ContractError);
  }
  SECTION("a bad configuration") {
    CHECK_THROWS_AS(Regulator(RegulatorConfig{1, {0}, {}}, nullptr), ContractError);
    // Account 1 has no entity.
    CHECK_THROWS_AS(Regulator(RegulatorConfig{1, {0, 2, 2}, {}}, make_interval_policy(params())),
                    ContractError);
  }
  CHECK(rig.out == Commands{{ms(2), 0, On}, {ms(2), 1, On}});
}

TEST_CASE("activation: the last RT finish at a boundary sends OFF alone, no REPLENISH",
          "[regulator][activation]") {
  Rig rig(make_interval_policy(params()), 1);
  rig.reg.rt_started(0, 0, rig.out);
  rig.sample(0, 0, 0);
  rig.sample(ms(2), 0, 20000);  // THR at 2 ms
  rig.reg.rt_finished(ms(5), 0, rig.out);
  CHECK(rig.out == Commands{{0, 0, On}, {ms(2), 0, Thr}, {ms(5), 0, Off}});
  CHECK_FALSE(rig.reg.next_tick().has_value());
}

TEST_CASE("regulator: a call rejected for its arguments does not move the clock",
          "[regulator][errors]") {
  Rig rig(make_interval_policy(params()), 1);
  rig.reg.rt_started(0, 0, rig.out);
  const std::vector<CounterValue> wrong(5);
  CHECK_THROWS(rig.reg.rt_started(ms(8), 3, rig.out));     // unknown RT node
  CHECK_THROWS(rig.reg.rt_finished(ms(8), 2, rig.out));    // unknown RT node
  CHECK_THROWS(rig.reg.sample(ms(9), 0, wrong, rig.out));  // wrong counter count
  // Had the rejected calls moved the clock to 8-9 ms, these inputs at 1 ms would be "late".
  CHECK_NOTHROW(rig.sample(ms(1), 0, 0));
  CHECK_NOTHROW(rig.reg.tick(ms(1), rig.out));
  CHECK(rig.out == Commands{{0, 0, On}});
}

// --- reconfiguration (rosguard guard's SIGHUP) ----------------------------------------------

TEST_CASE("set_policy: the open window keeps its budget, the next one opens under the new policy",
          "[regulator][interval][reload]") {
  Rig rig(make_interval_policy(params(ms(5))), 1);  // 20 %: 1 048 576 B per 5 ms
  rig.reg.rt_started(0, 0, rig.out);
  rig.sample(0, 0, 0);
  rig.sample(ms(1), 0, 8192);                                        // half the budget
  rig.reg.set_policy(make_interval_policy(params(ms(5), 0, 10.0)));  // 10 %: 524 288 B
  CHECK(rig.reg.accounts()[0].budget_bytes == 1048576.0);
  rig.sample(ms(2), 0, 8192);  // exactly the old budget: not over it
  CHECK(rig.out == Commands{{0, 0, On}});
  rig.reg.tick(ms(5), rig.out);  // the next window: the new budget, still active
  CHECK(rig.reg.active());
  CHECK(rig.reg.accounts()[0].budget_bytes == 524288.0);
  CHECK(rig.reg.next_tick() == ms(10));
  rig.sample(ms(5), 0, 0);     // the window's first reading (usage is charged by time)
  rig.sample(ms(6), 0, 8193);  // over the new budget, under the old one
  CHECK(rig.out == Commands{{0, 0, On}, {ms(6), 0, Thr}});
  // A policy that does not regulate cannot replace one that does.
  CHECK_THROWS_AS(rig.reg.set_policy(make_none_policy(params())), ContractError);
}

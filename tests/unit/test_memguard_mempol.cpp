// MemGuard and MemPol rule by rule (model/policy/memguard.cpp, mempol.cpp), and absolute budgets
// (budget_mbps) against threshold_pct. Expected command sequences are written out by hand;
// budgets come from the formula budget = MB/s x 1024 x 1024 B/s x period, with
//   budget_mbps 1000 over a 1 ms period = 1 048 576 B = 16 384 lines of 64 B (kBudgetLines).
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <vector>

#include "core/error.h"
#include "engine/controller_driver.h"
#include "regulator_support.h"

using namespace rosguard;
using namespace rosguard::test;

namespace {

// 1 ms periods, budget_mbps 1000: 16 384 lines per period and core.
PolicyParams mg_params(bool reclaim = false, Sharing sharing = Sharing::Off) {
  PolicyParams p = params(ms(1));
  p.budget_mbps = {1000.0};
  p.reclaim = reclaim;
  p.sharing = sharing;
  return p;
}

// Sets both counters of entity e (refills, write-backs) and samples them at t.
void sample_rw(Rig& rig, TimeNs t, std::size_t e, std::uint64_t reads, std::uint64_t writes) {
  auto& c = rig.counters.at(e);
  c[0].value += reads;
  c[1].value += writes;
  for (auto& v : c)
    v.time_enabled_ns = v.time_running_ns = static_cast<std::uint64_t>(t);
  rig.reg.sample(t, e, c, rig.out);
}

}  // namespace

// --- budget_mbps ---------------------------------------------------------------------------

TEST_CASE("budget_mbps: an absolute budget replaces threshold_pct x reference",
          "[policy][budget]") {
  std::vector<Account> accounts(2);
  SECTION("absent: threshold_pct % of the reference (20 % of 1000 MB/s over 5 ms)") {
    make_interval_policy(params())->open_window(0, accounts);
    CHECK(accounts[0].budget_bytes == kBudgetBytes);
  }
  SECTION("one value for every account: 200 MB/s over 5 ms is the same 1 048 576 B") {
    PolicyParams p = params();
    p.budget_mbps = {200.0};
    p.threshold_pct = 90.0;  // unused where budget_mbps is given
    make_interval_policy(p)->open_window(0, accounts);
    CHECK(accounts[0].budget_bytes == kBudgetBytes);
    CHECK(accounts[1].budget_bytes == kBudgetBytes);
  }
  SECTION("one per account: each its own") {
    PolicyParams p = params();
    p.budget_mbps = {200.0, 100.0};
    make_interval_policy(p)->open_window(0, accounts);
    CHECK(accounts[0].budget_bytes == kBudgetBytes);
    CHECK(accounts[1].budget_bytes == kBudgetBytes / 2);
  }
  SECTION("monolithic: over the RT isolation time, 400 MB/s x 12 ms = 5 033 164.8 B") {
    PolicyParams p = params(ms(5), ms(12));
    p.budget_mbps = {400.0};
    make_monolithic_policy(p)->open_window(0, accounts);
    CHECK(accounts[0].budget_bytes == Approx(5033164.8).epsilon(1e-12));
  }
  SECTION("memguard and mempol take it too") {
    make_memguard_policy(mg_params())->open_window(0, accounts);
    CHECK(accounts[0].budget_bytes == kBudgetBytes);
    PolicyParams p = mg_params();
    make_mempol_policy(p)->open_window(0, accounts);
    CHECK(accounts[1].budget_bytes == kBudgetBytes);
  }
  SECTION("more accounts than per-account budgets is a contract violation") {
    PolicyParams p = params();
    p.budget_mbps = {200.0, 100.0};
    std::vector<Account> three(3);
    CHECK_THROWS_AS(make_interval_policy(p)->open_window(0, three), ContractError);
  }
}

TEST_CASE("budget_mbps: the regulator throttles at the same point as the equivalent threshold",
          "[regulator][budget]") {
  for (const bool absolute : {false, true}) {
    PolicyParams p = params();
    if (absolute) p.budget_mbps = {200.0};
    Rig rig(make_interval_policy(p), 1);
    rig.reg.rt_started(0, 0, rig.out);
    rig.sample(0, 0, 0);
    rig.sample(ms(1), 0, kBudgetLines);
    rig.sample(ms(2), 0, 1);
    CHECK(rig.out == Commands{{0, 0, On}, {ms(2), 0, Thr}});
  }
}

// --- MemGuard ------------------------------------------------------------------------------

TEST_CASE("memguard: a budget per 1 ms period, replenished at every boundary",
          "[regulator][memguard]") {
  Rig rig(make_memguard_policy(mg_params()), 1);
  rig.reg.rt_started(0, 0, rig.out);
  CHECK(rig.reg.accounts()[0].budget_bytes == kBudgetBytes);
  CHECK(rig.reg.next_tick() == ms(1));
  rig.sample(0, 0, 0);
  rig.sample(us(500), 0, kBudgetLines + 1);
  rig.reg.tick(ms(1), rig.out);
  CHECK(rig.reg.accounts()[0].used_bytes == 0.0);
  rig.sample(ms(1), 0, 0);
  rig.sample(us(1900), 0, kBudgetLines);  // at the budget: not over it
  rig.reg.tick(ms(2), rig.out);
  CHECK(rig.out == Commands{{0, 0, On}, {us(500), 0, Thr}, {ms(1), 0, Rep}});
  CHECK(rig.reg.accounts()[0].window == 2);
}

TEST_CASE(
    "memguard: the overflow limit is the budget left from the last reading, and crossing it "
    "stops the core at once",
    "[regulator][memguard][overflow]") {
  Rig rig(make_memguard_policy(mg_params()), 1);
  CHECK(rig.reg.overflow_limits(0).empty());  // inactive: nothing to arm
  rig.reg.rt_started(0, 0, rig.out);
  CHECK(rig.reg.overflow_limits(0).empty());  // no baseline yet
  rig.sample(0, 0, 1000);                     // baseline: 1000 lines counted before
  auto limits = rig.reg.overflow_limits(0);
  REQUIRE(limits.size() == 1);
  CHECK(limits[0].bytes_per_count == std::vector<double>{64.0, 64.0});
  CHECK(limits[0].at_bytes == 1000.0 * 64 + kBudgetBytes);
  rig.sample(us(300), 0, 6384);  // 6 384 of 16 384 lines used
  limits = rig.reg.overflow_limits(0);
  REQUIRE(limits.size() == 1);
  CHECK(limits[0].at_bytes == (1000.0 + 6384 + 10000) * 64);
  // The interrupt's reading, one line past the limit: THR now, nothing left to arm.
  rig.sample(us(420), 0, 10001);
  CHECK(rig.out == Commands{{0, 0, On}, {us(420), 0, Thr}});
  CHECK(rig.reg.overflow_limits(0).empty());
  rig.reg.tick(ms(1), rig.out);  // the new period: armed again with a whole budget
  limits = rig.reg.overflow_limits(0);
  REQUIRE(limits.size() == 1);
  CHECK(limits[0].at_bytes == (1000.0 + 16385) * 64 + kBudgetBytes);
}

TEST_CASE("overflow_arm: one counter per event, each overflowing at or before its limit's crossing",
          "[regulator][memguard][overflow]") {
  const auto counts = [](std::vector<std::uint64_t> v) {
    std::vector<CounterValue> out;
    for (auto x : v)
      out.push_back({x, 0, 0});
    return out;
  };
  SECTION("one event: the counts left, plus one to exceed") {
    const std::vector<OverflowLimit> l{{{64.0}, 64.0 * 1100}};
    CHECK(overflow_arm(l, counts({1000})) == OverflowArm{false, {101}});
    CHECK(overflow_arm(l, counts({1100})) == OverflowArm{false, {1}});  // at it: the next count
    CHECK(overflow_arm(l, counts({1101})) == OverflowArm{true, {0}});   // past it: read now
  }
  SECTION("a weighted sum over two events: each gets half of what is left") {
    // 6400 bytes left: 50 lines on either counter, at 64 bytes each.
    const std::vector<OverflowLimit> l{{{64.0, 64.0}, 64.0 * (10 + 20) + 6400}};
    const OverflowArm a = overflow_arm(l, counts({10, 20}));
    CHECK(a == OverflowArm{false, {51, 51}});
    // Neither counter reaching its period leaves the sum at or under the limit.
    CHECK(64.0 * (10 + 50) + 64.0 * (20 + 50) <= l[0].at_bytes);
  }
  SECTION("after a previous arm: shares follow each event's bytes since, a quiet one keeps 1/8") {
    // 6400 bytes left; since the previous arm only the first event counted (50 lines).
    const std::vector<OverflowLimit> l{{{64.0, 64.0}, 64.0 * (60 + 20) + 6400}};
    const std::vector<std::uint64_t> previous{10, 20};
    const OverflowArm a = overflow_arm(l, counts({60, 20}), previous);
    // 15/16 and 1/16 of what is left: 93.75 and 6.25 lines, each plus one to exceed.
    CHECK(a == OverflowArm{false, {94, 7}});
    CHECK(64.0 * (60 + 93) + 64.0 * (20 + 6) <= l[0].at_bytes);  // still at or before the limit
    // Both counted alike, or neither did: even, as without a previous arm.
    CHECK(overflow_arm(l, counts({60, 20}), std::vector<std::uint64_t>{40, 0}) ==
          OverflowArm{false, {51, 51}});
    CHECK(overflow_arm(l, counts({60, 20}), std::vector<std::uint64_t>{60, 20}) ==
          OverflowArm{false, {51, 51}});
  }
  SECTION("per-event limits: each on its own event; a total and a per-event limit take the least") {
    const std::vector<OverflowLimit> l{{{0.0, 64.0}, 64.0 * 100},  // writes: 100 lines
                                       {{64.0, 64.0}, 64.0 * 1000}};
    CHECK(overflow_arm(l, counts({0, 0})) == OverflowArm{false, {501, 101}});
    CHECK(overflow_arm(l, counts({0, 40})) == OverflowArm{false, {481, 61}});
    CHECK(overflow_arm(std::span(l).first(1), counts({0, 0})) == OverflowArm{false, {0, 101}});
  }
  SECTION("no limit: nothing to arm") {
    CHECK(overflow_arm({}, counts({5, 5})) == OverflowArm{false, {0, 0}});
  }
  SECTION("arming from the regulator's limits: the interrupt's reading throttles") {
    Rig rig(make_memguard_policy(mg_params()), 1);
    rig.reg.rt_started(0, 0, rig.out);
    rig.sample(0, 0, 1000);
    const auto limits = rig.reg.overflow_limits(0);
    const auto arm = overflow_arm(limits, counts({1000, 0}));
    REQUIRE(!arm.due);
    // The first counter to overflow (either one, each at half the budget) is read ...
    rig.sample(us(100), 0, arm.periods[0]);
    CHECK(rig.out == Commands{{0, 0, On}});
    // ... and arming again from that reading leaves the other half.
    const auto next = overflow_arm(rig.reg.overflow_limits(0), counts({1000 + arm.periods[0], 0}));
    CHECK(next.periods[0] < arm.periods[0]);
  }
}

TEST_CASE("memguard: separate read and write budgets through the metric's events",
          "[regulator][memguard][events]") {
  // Reads (l2d_cache_refill) 1000 MB/s, write-backs (l2d_cache_wb) 250 MB/s: 16 384 and 4 096
  // lines per 1 ms period.
  PolicyParams p = mg_params();
  p.event_budget_mbps = {1000.0, 250.0};
  SECTION("write-backs over their budget throttle, whatever the reads") {
    Rig rig(make_memguard_policy(p), 1);
    rig.reg.rt_started(0, 0, rig.out);
    CHECK(std::isinf(rig.reg.accounts()[0].budget_bytes));  // the total is replaced
    sample_rw(rig, 0, 0, 0, 0);
    sample_rw(rig, us(200), 0, 100, 4096);  // writes at their budget
    CHECK(rig.out == Commands{{0, 0, On}});
    sample_rw(rig, us(300), 0, 0, 1);
    CHECK(rig.out == Commands{{0, 0, On}, {us(300), 0, Thr}});
  }
  SECTION("reads over theirs throttle; writes far under") {
    Rig rig(make_memguard_policy(p), 1);
    rig.reg.rt_started(0, 0, rig.out);
    sample_rw(rig, 0, 0, 0, 0);
    sample_rw(rig, us(200), 0, 16385, 10);
    CHECK(rig.out == Commands{{0, 0, On}, {us(200), 0, Thr}});
  }
  SECTION("18 000 lines in all, neither budget exceeded: no throttle (a total budget would)") {
    Rig rig(make_memguard_policy(p), 1);
    rig.reg.rt_started(0, 0, rig.out);
    sample_rw(rig, 0, 0, 0, 0);
    sample_rw(rig, us(200), 0, 14000, 4000);
    CHECK(rig.out == Commands{{0, 0, On}});
  }
  SECTION("one overflow limit per event budget, on that event alone") {
    Rig rig(make_memguard_policy(p), 1);
    rig.reg.rt_started(0, 0, rig.out);
    sample_rw(rig, 0, 0, 10, 20);
    const auto limits = rig.reg.overflow_limits(0);
    REQUIRE(limits.size() == 2);
    CHECK(limits[0].bytes_per_count == std::vector<double>{64.0, 0.0});
    CHECK(limits[0].at_bytes == 10.0 * 64 + kBudgetBytes);
    CHECK(limits[1].bytes_per_count == std::vector<double>{0.0, 64.0});
    CHECK(limits[1].at_bytes == 20.0 * 64 + kBudgetBytes / 4);
  }
}

TEST_CASE("memguard reclaim: a core donates what it is predicted not to use, another reclaims it",
          "[regulator][memguard][reclaim]") {
  Rig rig(make_memguard_policy(mg_params(true)), 2);
  rig.reg.rt_started(0, 0, rig.out);
  rig.sample(0, 0, 0);
  rig.sample(0, 1, 0);
  // Period 0: no prediction yet, no donation. Core 0 uses 4 096 lines, core 1 its whole budget.
  CHECK(rig.reg.global().pool_bytes == 0.0);
  rig.sample(us(900), 0, 4096);
  rig.sample(us(900), 1, kBudgetLines);
  rig.reg.tick(ms(1), rig.out);
  rig.sample(ms(1), 0, 0);
  rig.sample(ms(1), 1, 0);
  // Period 1: core 0 predicts 4 096 lines (its only history) and donates 12 288 lines; core 1
  // predicts its whole budget and donates nothing.
  const auto& acc = rig.reg.accounts();
  CHECK(acc[0].predicted_bytes == 4096.0 * 64);
  CHECK(acc[0].budget_bytes == 4096.0 * 64);
  CHECK(acc[0].assigned_bytes == kBudgetBytes);
  CHECK(acc[1].budget_bytes == kBudgetBytes);
  CHECK(rig.reg.global().pool_bytes == 12288.0 * 64);
  // Core 1 exhausts its budget and reclaims from the pool instead of being throttled.
  rig.sample(us(1500), 1, kBudgetLines + 5000);
  CHECK(rig.out == Commands{{0, 0, On}, {0, 1, On}});
  CHECK(acc[1].budget_bytes == (kBudgetLines + 12288.0) * 64);
  CHECK(rig.reg.global().pool_bytes == 0.0);
  // Core 0 goes past its prediction: its reservation is guaranteed although the pool is empty.
  rig.sample(us(1600), 0, 10000);
  CHECK(rig.out == Commands{{0, 0, On}, {0, 1, On}});
  CHECK(acc[0].budget_bytes == kBudgetBytes);
  CHECK(acc[0].shortfall);
  // Past the reclaimed budget, with nothing left in the pool: throttled at once.
  rig.sample(us(1700), 1, 7289);
  CHECK(rig.out == Commands{{0, 0, On}, {0, 1, On}, {us(1700), 1, Thr}});
  // The shortfall sets core 0's next prediction to its reservation: no donation in period 2.
  rig.reg.tick(ms(2), rig.out);
  CHECK(acc[0].predicted_bytes == kBudgetBytes);
  CHECK(acc[0].budget_bytes == kBudgetBytes);
}

TEST_CASE("memguard reclaim off: the same usage throttles at the reservation",
          "[regulator][memguard][reclaim]") {
  Rig rig(make_memguard_policy(mg_params(false)), 2);
  rig.reg.rt_started(0, 0, rig.out);
  rig.sample(0, 0, 0);
  rig.sample(0, 1, 0);
  rig.sample(us(900), 0, 4096);
  rig.reg.tick(ms(1), rig.out);
  rig.sample(ms(1), 1, 0);  // the period timer's reading
  CHECK(rig.reg.global().pool_bytes == 0.0);
  CHECK(rig.reg.accounts()[0].budget_bytes == kBudgetBytes);
  rig.sample(us(1500), 1, kBudgetLines + 1);
  CHECK(rig.out == Commands{{0, 0, On}, {0, 1, On}, {us(1500), 1, Thr}});
}

TEST_CASE("memguard sharing: when every core is exhausted", "[regulator][memguard][sharing]") {
  const auto run = [](Sharing sharing) {
    Rig rig(make_memguard_policy(mg_params(false, sharing)), 2);
    rig.reg.rt_started(0, 0, rig.out);
    rig.sample(0, 0, 0);
    rig.sample(0, 1, 0);
    rig.sample(us(100), 0, kBudgetLines + 1);
    rig.sample(us(200), 1, kBudgetLines + 1);
    rig.sample(us(300), 1, 5000);
    return rig.out;
  };
  SECTION("off: both throttled until the period ends") {
    CHECK(run(Sharing::Off) ==
          Commands{{0, 0, On}, {0, 1, On}, {us(100), 0, Thr}, {us(200), 1, Thr}});
  }
  SECTION("last: the last one to exhaust its budget runs on") {
    CHECK(run(Sharing::Last) == Commands{{0, 0, On}, {0, 1, On}, {us(100), 0, Thr}});
  }
  SECTION("all: every core released for the rest of the period") {
    CHECK(run(Sharing::All) ==
          Commands{{0, 0, On}, {0, 1, On}, {us(100), 0, Thr}, {us(200), 0, Rep}});
  }
}

// --- MemPol --------------------------------------------------------------------------------

TEST_CASE("mempol: per-core shares plus a global cap across the cores", "[regulator][mempol]") {
  // Shares 1000 MB/s each (16 384 lines per ms), cap 1500 MB/s for all three (24 576 lines).
  PolicyParams p = mg_params();
  p.global_budget_mbps = 1500.0;
  SECTION("each core under its share, together over the cap: every core halted") {
    Rig rig(make_mempol_policy(p), 3);
    rig.reg.rt_started(0, 0, rig.out);
    for (std::size_t e = 0; e < 3; ++e)
      rig.sample(0, e, 0);
    rig.sample(us(100), 0, 10000);
    rig.sample(us(105), 1, 10000);
    CHECK(rig.reg.global().used_bytes == 20000.0 * 64);
    rig.sample(us(110), 2, 4577);  // 24 577 lines together
    CHECK(rig.out == Commands{{0, 0, On},
                              {0, 1, On},
                              {0, 2, On},
                              {us(110), 0, Thr},
                              {us(110), 1, Thr},
                              {us(110), 2, Thr}});
    CHECK(rig.reg.global().capped);
    rig.sample(us(115), 0, 1000);  // no second round
    rig.reg.tick(ms(1), rig.out);
    CHECK(rig.out.size() == 9);  // every core resumed at the boundary
    CHECK(rig.out[6] == CommandOut{ms(1), 0, Rep});
    CHECK(rig.out[8] == CommandOut{ms(1), 2, Rep});
    CHECK_FALSE(rig.reg.global().capped);
    CHECK(rig.reg.global().used_bytes == 0.0);
  }
  SECTION("one core over its share alone: only it is halted") {
    Rig rig(make_mempol_policy(p), 3);
    rig.reg.rt_started(0, 0, rig.out);
    for (std::size_t e = 0; e < 3; ++e)
      rig.sample(0, e, 0);
    rig.sample(us(100), 1, kBudgetLines + 1);
    CHECK(rig.out == Commands{{0, 0, On}, {0, 1, On}, {0, 2, On}, {us(100), 1, Thr}});
  }
  SECTION("no global budget: no cap") {
    Rig rig(make_mempol_policy(mg_params()), 3);
    rig.reg.rt_started(0, 0, rig.out);
    CHECK(std::isinf(rig.reg.global().cap_bytes));
    for (std::size_t e = 0; e < 3; ++e)
      rig.sample(0, e, 0);
    for (std::size_t e = 0; e < 3; ++e)
      rig.sample(us(100), e, 16000);
    CHECK(rig.out == Commands{{0, 0, On}, {0, 1, On}, {0, 2, On}});
  }
}

TEST_CASE("memguard and mempol reject a regulation period that is not positive", "[policy]") {
  CHECK_THROWS_AS(make_memguard_policy(params(0)), ContractError);
  CHECK_THROWS_AS(make_mempol_policy(params(0)), ContractError);
}

// --- the engine under overflow sampling ----------------------------------------------------

TEST_CASE(
    "controller driver, overflow sampling: a baseline read at the activation, one at every "
    "boundary, no periodic reads, and re-arming after every input",
    "[engine][controller][overflow]") {
  RegulatorConfig rc;
  rc.account_of_entity = accounts_for_scope(Scope::Core, 1);
  ControllerDriver driver({Sampling::Overflow, us(200), 0, false},
                          std::make_unique<Regulator>(rc, make_memguard_policy(mg_params())),
                          nullptr);
  DriverOutput out;
  driver.rt_signal(0, 0, true, out);
  CHECK(out.rearm == std::vector<std::size_t>{0});
  CHECK(driver.next_read() == 0);
  driver.read_due(0, out);
  CHECK(out.reads == std::vector<std::size_t>{0});
  CHECK_FALSE(driver.next_read().has_value());  // no sampling period
  out.clear();
  const std::vector<CounterValue> c0{{0, 0, 0}, {0, 0, 0}};
  driver.sample(0, 0, c0, 0, out);
  CHECK(out.rearm == std::vector<std::size_t>{0});
  REQUIRE(driver.regulator().overflow_limits(0).size() == 1);
  out.clear();
  driver.tick(ms(1), out);
  CHECK(out.reads == std::vector<std::size_t>{0});
  CHECK(out.rearm == std::vector<std::size_t>{0});
}

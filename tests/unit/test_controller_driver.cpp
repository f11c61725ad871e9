// The controller engine (model/engine/controller_driver.h): activation edges, the external
// sampling schedule, regulation ticks, keep-alives and the accounting, rule by rule. Budgets use
// the reference setup of regulator_support.h (20 % of 1000 MB/s over 5 ms = 16 384 lines).
#include <catch2/catch.hpp>
#include <map>
#include <memory>
#include <vector>

#include "engine/controller_driver.h"
#include "regulator_support.h"

using namespace rosguard;
using namespace rosguard::test;

namespace {

// Readings the test sets by hand; records when the driver read them.
struct FakeMeter : EntityMeter {
  std::map<std::size_t, EntityReading> now;
  std::vector<std::pair<std::size_t, TimeNs>> reads;
  EntityReading read(std::size_t e, TimeNs t) override {
    reads.emplace_back(e, t);
    return now[e];
  }
};

struct DriverRig {
  FakeMeter meter;
  ControllerDriver driver;
  DriverOutput out;
  DriverRig(ControllerDriverConfig cfg, std::unique_ptr<Policy> policy, std::size_t entities)
      : driver(cfg, make_regulator(std::move(policy), entities), &meter) {}

  static std::unique_ptr<Regulator> make_regulator(std::unique_ptr<Policy> p, std::size_t n) {
    RegulatorConfig rc;
    rc.account_of_entity = accounts_for_scope(Scope::Core, n);
    return std::make_unique<Regulator>(rc, std::move(p));
  }
  // Cumulative L2 refills (write-backs 0) of entity e, measured at `measured`, processed at t.
  void sample(TimeNs t, std::size_t e, std::uint64_t lines, TimeNs measured) {
    const std::vector<CounterValue> c{{lines, 0, 0}, {0, 0, 0}};
    driver.sample(t, e, c, measured, out);
  }
};

ControllerDriverConfig self_cfg() {
  return {Sampling::Self, ms(1), 0, false};
}

}  // namespace

TEST_CASE("controller driver: an activation sends ON, closes with OFF and is accounted",
          "[engine][controller]") {
  DriverRig rig(self_cfg(), make_interval_policy(params()), 2);
  rig.meter.now[0] = {100.0, 1000.0, 1.0};
  rig.meter.now[1] = {200.0, 2000.0, 2.0};
  rig.driver.rt_signal(ms(2), 0, true, rig.out);
  CHECK(rig.out.commands == std::vector<DriverCommand>{{ms(2), 0, On, -1}, {ms(2), 1, On, -1}});
  REQUIRE(rig.out.events.size() == 1);
  CHECK(rig.out.events[0].kind == EngineEvent::Kind::ActivationBegin);
  CHECK(rig.driver.next_tick() == ms(7));
  CHECK_FALSE(rig.driver.next_read());  // self-sampling: the nodes sample themselves
  CHECK_FALSE(rig.driver.next_keepalive());

  rig.out.clear();
  rig.meter.now[0] = {1100.0, 5000.0, 3.5};
  rig.meter.now[1] = {200.0, 2000.0, 2.0};
  rig.driver.rt_signal(ms(5), 0, false, rig.out);
  CHECK(rig.out.commands == std::vector<DriverCommand>{{ms(5), 0, Off, -1}, {ms(5), 1, Off, -1}});
  CHECK(rig.out.events.back().kind == EngineEvent::Kind::ActivationEnd);
  CHECK_FALSE(rig.driver.next_tick());
  const ActivationTotals& tot = rig.driver.totals();
  CHECK(tot.activations == 1);
  CHECK(tot.active_ns == ms(3));
  CHECK(tot.active[0].bytes == 1000.0);
  CHECK(tot.active[0].cycles == 4000.0);
  CHECK(tot.active[0].work == 2.5);
  CHECK(tot.active[1].bytes == 0.0);
}

TEST_CASE("controller driver: commands carry the measurement time of their sample",
          "[engine][controller]") {
  DriverRig rig(self_cfg(), make_interval_policy(params()), 1);
  rig.driver.rt_signal(0, 0, true, rig.out);
  rig.sample(us(10), 0, 0, us(5));  // baseline
  rig.sample(ms(1) + us(20), 0, kBudgetLines + 1, ms(1));
  CHECK(rig.out.commands.back() == DriverCommand{ms(1) + us(20), 0, Thr, ms(1)});
  CHECK(rig.out.events.back().kind == EngineEvent::Kind::BudgetUsed);
  CHECK(rig.out.events.back().value > 100.0);
  rig.out.clear();
  rig.driver.tick(ms(5) + us(3), rig.out);  // served late: the window still ends at 5 ms
  CHECK(rig.out.commands == std::vector<DriverCommand>{{ms(5) + us(3), 0, Rep, -1}});
  CHECK(rig.driver.next_tick() == ms(10));
}

TEST_CASE("controller driver: external sampling reads at the activation, then every period",
          "[engine][controller]") {
  DriverRig rig({Sampling::External, ms(1), 0, false}, make_interval_policy(params()), 2);
  rig.driver.rt_signal(ms(2), 0, true, rig.out);
  CHECK(rig.out.reads.empty());
  CHECK(rig.driver.next_read() == ms(2));  // the baselines, right away
  rig.driver.read_due(ms(2), rig.out);
  CHECK(rig.out.reads == std::vector<std::size_t>{0, 1});
  CHECK(rig.driver.next_read() == ms(3));
  rig.out.clear();
  rig.driver.read_due(ms(2) + us(999), rig.out);  // not due yet
  CHECK(rig.out.reads.empty());
  SECTION("a late host skips the periods it missed and stays on the grid") {
    rig.driver.read_due(ms(5) + us(500), rig.out);
    CHECK(rig.out.reads.size() == 2);
    CHECK(rig.driver.next_read() == ms(6));
  }
  SECTION("the reads stop with the activation") {
    rig.driver.rt_signal(ms(4), 0, false, rig.out);
    CHECK_FALSE(rig.driver.next_read());
  }
  SECTION("an unregulated co-run reads nothing") {
    DriverRig none({Sampling::External, ms(1), 0, false}, make_none_policy(params()), 2);
    none.driver.rt_signal(0, 0, true, none.out);
    CHECK_FALSE(none.driver.next_read());
    CHECK(none.out.commands.empty());
    CHECK(none.driver.totals().activations == 1);  // still accounted
  }
}

TEST_CASE("controller driver: keep-alives while an entity is not OFF", "[engine][controller]") {
  DriverRig rig({Sampling::Self, ms(1), ms(25), false}, make_interval_policy(params()), 2);
  CHECK_FALSE(rig.driver.next_keepalive());
  rig.driver.rt_signal(ms(1), 0, true, rig.out);
  CHECK(rig.driver.next_keepalive() == ms(1));  // the first one right away
  rig.out.clear();
  rig.driver.keepalive_due(ms(1), rig.out);
  CHECK(rig.out.keepalives == std::vector<std::size_t>{0, 1});
  CHECK(rig.driver.next_keepalive() == ms(26));
  rig.out.clear();
  rig.driver.keepalive_due(ms(20), rig.out);
  CHECK(rig.out.keepalives.empty());
  rig.driver.rt_signal(ms(30), 0, false, rig.out);
  CHECK_FALSE(rig.driver.next_keepalive());
}

TEST_CASE("controller driver: window accounting and wake-ups", "[engine][controller]") {
  DriverRig rig({Sampling::External, ms(2), 0, true}, make_interval_policy(params()), 1);
  rig.meter.now[0] = {640.0, 0.0, 0.0};
  rig.driver.rt_signal(0, 0, true, rig.out);
  CHECK(rig.driver.next_window() == ms(5));
  CHECK(rig.driver.next_wakeup() == 0);  // the baseline read
  rig.meter.now[0] = {6400.0, 0.0, 0.0};
  rig.out.clear();
  rig.driver.wake(ms(5), rig.out);  // tick, read and window, all due
  CHECK(rig.out.reads == std::vector<std::size_t>{0});
  REQUIRE(rig.driver.windows().size() == 1);
  CHECK(rig.driver.windows()[0] == WindowUsage{0, 0, 0, ms(5), 5760.0, true});
  CHECK(rig.driver.next_wakeup() == ms(6));
  rig.meter.now[0] = {7040.0, 0.0, 0.0};
  rig.driver.rt_signal(ms(7), 0, false, rig.out);
  REQUIRE(rig.driver.windows().size() == 2);
  CHECK(rig.driver.windows()[1] == WindowUsage{0, 1, ms(5), ms(7), 640.0, false});
  CHECK_FALSE(rig.driver.next_wakeup());
}

TEST_CASE("controller driver: finish() closes an open activation's accounting only",
          "[engine][controller]") {
  DriverRig rig(self_cfg(), make_interval_policy(params()), 1);
  rig.driver.rt_signal(ms(1), 0, true, rig.out);
  rig.out.clear();
  rig.driver.finish(ms(4), rig.out);
  CHECK(rig.out.commands.empty());
  CHECK(rig.driver.totals().active_ns == ms(3));
}

TEST_CASE(
    "controller driver: with a known top rate, a read is due when the budget's remainder could "
    "be spent, and at each window's start",
    "[engine][controller]") {
  // The budget (16 384 lines x 64 B per 5 ms window) takes 2 ms to spend at the top rate.
  const double rate = static_cast<double>(kBudgetLines) * 64.0 / static_cast<double>(ms(2));
  DriverRig rig({Sampling::External, ms(1), 0, false, rate}, make_interval_policy(params()), 1);
  rig.driver.rt_signal(0, 0, true, rig.out);
  rig.driver.read_due(0, rig.out);
  rig.sample(us(5), 0, 0, 0);  // baseline: 2 ms of budget left, after the next periodic read
  CHECK(rig.driver.next_read() == ms(1));
  rig.driver.read_due(ms(1), rig.out);
  rig.sample(ms(1) + us(5), 0, kBudgetLines * 3 / 4, ms(1));  // a quarter left: 0.5 ms
  CHECK(rig.driver.next_read() == ms(1) + us(5) + us(500));
  rig.out.clear();
  rig.driver.read_due(ms(1) + us(505), rig.out);
  CHECK(rig.out.reads == std::vector<std::size_t>{0});
  CHECK(rig.driver.next_read() == ms(2));                              // the periodic grid goes on
  rig.sample(ms(1) + us(510), 0, kBudgetLines - 10, ms(1) + us(505));  // 10 lines left
  CHECK(rig.driver.next_read() == ms(1) + us(510) + kMinPacedReadNs);  // not sooner
  rig.sample(ms(1) + us(540), 0, kBudgetLines + 1, ms(1) + us(535));
  CHECK(rig.out.commands.back().command == Thr);
  CHECK(rig.driver.next_read() == ms(2));  // throttled: nothing to run out
  rig.out.clear();
  rig.driver.tick(ms(5), rig.out);  // replenished: the new window starts from a reading
  CHECK(rig.out.commands == std::vector<DriverCommand>{{ms(5), 0, Rep, -1}});
  CHECK(rig.out.reads == std::vector<std::size_t>{0});
  SECTION("without a top rate, reads stay on the grid") {
    DriverRig grid({Sampling::External, ms(1), 0, false}, make_interval_policy(params()), 1);
    grid.driver.rt_signal(0, 0, true, grid.out);
    grid.driver.read_due(0, grid.out);
    grid.sample(us(5), 0, 0, 0);
    grid.sample(ms(1) + us(5), 0, kBudgetLines * 3 / 4, ms(1));
    CHECK(grid.driver.next_read() == ms(1));
  }
}

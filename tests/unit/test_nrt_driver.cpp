// The nRT engine (model/engine/nrt_driver.h): each command's side effects, the throttle
// bookkeeping, the watchdog, and the self-sampling period timer.
#include <catch2/catch.hpp>

#include "engine/nrt_driver.h"
#include "regulator_support.h"

using namespace rosguard;
using namespace rosguard::test;

TEST_CASE("nRT driver: ON takes a baseline under self-sampling only", "[engine][nrt]") {
  NrtDriver self(Sampling::Self);
  const NrtEffects fx = self.command(ms(1), Command::On, -1);
  CHECK(fx.transition.to == NodeState::On);
  CHECK(fx.baseline);
  CHECK(self.command(ms(2), Command::On, -1).baseline);  // a new activation: a new baseline
  NrtDriver external(Sampling::External);
  CHECK_FALSE(external.command(ms(1), Command::On, -1).baseline);
}

TEST_CASE("nRT driver: throttles are counted and timed from THR to REPLENISH / OFF",
          "[engine][nrt]") {
  NrtDriver d(Sampling::Self);
  CHECK_FALSE(d.command(0, Command::Thr, 0).throttle);  // never throttled outside activation
  d.command(ms(1), Command::On, -1);
  const NrtEffects thr = d.command(ms(3), Command::Thr, ms(3) - us(150));
  CHECK(thr.throttle);
  CHECK(thr.activation_delay_ns == us(150));
  CHECK(d.throttles() == 1);
  CHECK_FALSE(d.command(ms(4), Command::Thr, -1).throttle);  // already throttled
  const NrtEffects rep = d.command(ms(5), Command::Replenish, -1);
  CHECK(rep.unthrottle);
  CHECK(rep.resume);
  CHECK(d.throttled_ns() == ms(2));
  d.command(ms(6), Command::Thr, -1);
  const NrtEffects off = d.command(ms(7), Command::Off, -1);
  CHECK(off.unthrottle);
  CHECK(off.stop_sampling);
  CHECK(d.throttles() == 2);
  CHECK(d.throttled_ns() == ms(3));
  SECTION("finish() closes a throttle still open") {
    d.command(ms(8), Command::On, -1);
    d.command(ms(9), Command::Thr, -1);
    d.finish(ms(12));
    CHECK(d.throttled_ns() == ms(6));
  }
}

TEST_CASE("nRT driver: the watchdog returns a silent node to nominal", "[engine][nrt]") {
  NrtDriver d(Sampling::Self, ms(100));
  CHECK_FALSE(d.watchdog_deadline());  // OFF: nothing to guard
  d.heard(ms(1));
  d.command(ms(1), Command::On, -1);
  d.command(ms(2), Command::Thr, -1);
  d.heard(ms(30));
  CHECK(d.watchdog_deadline() == ms(130));
  const NrtEffects fx = d.watchdog(ms(130));
  CHECK(fx.transition.to == NodeState::Off);
  CHECK(fx.unthrottle);
  CHECK(d.watchdog_fired() == 1);
  CHECK_FALSE(d.watchdog_deadline());
  NrtDriver none(Sampling::Self);
  none.command(0, Command::On, -1);
  CHECK_FALSE(none.watchdog_deadline());  // no watchdog configured
}

TEST_CASE("sample schedule: a fixed grid, an owed sample made up once", "[engine][nrt]") {
  SampleSchedule s(ms(1));
  CHECK_FALSE(s.next());
  s.restart(ms(10));
  CHECK(s.next() == ms(11));
  CHECK_FALSE(s.elapsed(ms(10) + us(500), true));  // not yet
  CHECK(s.elapsed(ms(11), true));
  CHECK(s.next() == ms(12));
  CHECK_FALSE(s.take_owed());
  CHECK_FALSE(s.elapsed(ms(12), false));  // throttled: owed
  CHECK(s.next() == ms(13));
  CHECK(s.elapsed(ms(15) + us(300), true));  // late: the grid is kept, missed periods skipped
  CHECK(s.next() == ms(16));
  CHECK(s.take_owed());
  CHECK_FALSE(s.take_owed());
  s.defer();
  s.stop();
  CHECK_FALSE(s.next());
  CHECK_FALSE(s.take_owed());
}

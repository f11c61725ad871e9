// The shared-cache model (model/cache/shared_lru.h) against the cases LRU is known for.
#include <catch2/catch.hpp>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "cache/shared_lru.h"

using rosguard::cache::MissRatioCurve;
using rosguard::cache::natural_partition;
using rosguard::cache::Tenant;

namespace {
constexpr double kLine = 64.0 / 1024.0;  // KB
constexpr double kL3 = 2048.0;           // KB
}  // namespace

TEST_CASE("miss-ratio curves: interpolation, monotone, steps are right-continuous", "[cache]") {
  const auto m = MissRatioCurve::from_points({{1024, 0.5}, {512, 0.6}, {2048, 0.7}});
  CHECK(m.miss_ratio(0) == 1.0);  // (0, 1) prepended
  CHECK(m.miss_ratio(256) == Approx(0.8));
  CHECK(m.miss_ratio(768) == Approx(0.55));
  CHECK(m.miss_ratio(2048) == Approx(0.5));  // running minimum: 0.7 -> 0.5
  CHECK(m.miss_ratio(1e6) == Approx(0.5));   // constant beyond the last point
  const auto s = MissRatioCurve::step(2048, 1.0, 0.03);
  CHECK(s.miss_ratio(2047.9) == 1.0);
  CHECK(s.miss_ratio(2048) == 0.03);
  CHECK(MissRatioCurve::step(4096, 1.0, 0.0).saturation_kb() == 4096);
  CHECK(std::isinf(s.saturation_kb()));
  CHECK_THROWS_AS(MissRatioCurve::from_points({{-1, 0.5}}), std::invalid_argument);
  CHECK_THROWS_AS(MissRatioCurve::from_points({{10, 1.5}}), std::invalid_argument);
}

TEST_CASE("the uniform-reuse default keeps the measured hit ratio at the capacity", "[cache]") {
  for (double f : {256.0, 1536.0, 2048.0, 3000.0, 8192.0, 65536.0})
    for (double h : {0.0, 0.06, 0.5, 0.9, 0.97, 1.0}) {
      const auto m = MissRatioCurve::uniform_reuse(f, h, kL3);
      INFO("footprint " << f << " hit " << h);
      CHECK(m.miss_ratio(kL3) == Approx(1.0 - h).margin(1e-12));
      CHECK(m.miss_ratio(0.0) == 1.0);
      CHECK(m.miss_ratio(2 * f) <= m.miss_ratio(f / 2));
    }
  // Within the footprint: linear from 1 to 1 - h.
  CHECK(MissRatioCurve::uniform_reuse(1024, 0.9, kL3).miss_ratio(512) == Approx(0.55));
}

TEST_CASE("footprint is the inverse of fill time, the HOTL occupancy curve", "[cache]") {
  const auto m = MissRatioCurve::from_points({{512, 0.4}, {1024, 0.4}, {4096, 0.1}});
  for (double kb : {10.0, 300.0, 512.0, 700.0, 2000.0, 5000.0}) {
    const double t = m.fill_time(kb, 3.0, kLine);
    CHECK(m.footprint(t, 3.0, kLine) == Approx(kb).epsilon(1e-9));
  }
  // On the first piece m(c) = 1 - r c / D: fp(t) = D / r (1 - exp(-r a b t / D)).
  const auto u = MissRatioCurve::uniform_reuse(512, 0.9, kL3);
  const double a = 0.01, t = 3e4;
  CHECK(u.footprint(t, a, kLine) ==
        Approx(512 / 0.9 * (1 - std::exp(-0.9 * a * kLine * t / 512))).epsilon(1e-9));
  // A curve that reaches 0 never grows past that point.
  const auto w = MissRatioCurve::step(1024, 1.0, 0.0);
  CHECK(w.footprint(1e12, 1.0, kLine) == 1024);
  CHECK(std::isinf(w.fill_time(1025, 1.0, kLine)));
}

TEST_CASE("one stream larger than the cache misses on (nearly) every access", "[cache]") {
  // A cyclic stream over 4 MB through a 2 MB LRU cache: each line's reuse distance is 4 MB.
  const auto stream = MissRatioCurve::step(4096, 1.0, 0.0);
  const Tenant t{&stream, 0.2};
  const std::vector<double> occ = natural_partition({&t, 1}, kL3, kLine);
  CHECK(occ[0] == Approx(kL3).epsilon(1e-9));  // it fills the cache...
  CHECK(stream.miss_ratio(occ[0]) == 1.0);     // ...and every access misses
  // Within the cache it keeps its working set and hits.
  const auto small = MissRatioCurve::step(1024, 1.0, 0.0);
  const Tenant s{&small, 0.2};
  CHECK(natural_partition({&s, 1}, kL3, kLine)[0] == 1024);
  CHECK(small.miss_ratio(1024) == 0.0);
}

TEST_CASE("two streams that together exceed the cache lose their hits under LRU", "[cache]") {
  // Two 2 MB cyclic streams (the built-in bandwidth_read's derived curve: 3 % misses when it
  // has the L3 to itself) in one 2 MB L3: alone each hits 97 %.
  const auto stream = MissRatioCurve::step(2048, 1.0, 0.03);
  CHECK(1 - stream.miss_ratio(
                natural_partition(std::vector<Tenant>{{&stream, 0.2}}, kL3, kLine)[0]) ==
        Approx(0.97));
  for (double ratio : {1.0, 1.5, 3.0}) {
    const std::vector<Tenant> both{{&stream, 0.2}, {&stream, 0.2 * ratio}};
    const std::vector<double> occ = natural_partition(both, kL3, kLine);
    INFO("rate ratio " << ratio);
    CHECK(occ[0] + occ[1] == Approx(kL3).epsilon(1e-9));
    CHECK(occ[1] / occ[0] == Approx(ratio).epsilon(1e-9));  // equal age: shares ~ insertions
    CHECK(stream.miss_ratio(occ[0]) == 1.0);                // both now miss on every access
    CHECK(stream.miss_ratio(occ[1]) == 1.0);
  }
  // 1.5 MB + 1.5 MB streams: 3 MB together, each fits alone; together each holds 1 MB and
  // misses always.
  const auto s15 = MissRatioCurve::step(1536, 1.0, 0.0);
  const std::vector<Tenant> two{{&s15, 0.1}, {&s15, 0.1}};
  const std::vector<double> occ = natural_partition(two, kL3, kLine);
  CHECK(occ[0] == Approx(1024).epsilon(1e-9));
  CHECK(s15.miss_ratio(occ[0]) == 1.0);
}

TEST_CASE("a small footprint beside a stream keeps the share its insertion rate sets", "[cache]") {
  // 512 KB of uniformly reused data (90 % hits alone) beside a stream that never hits.
  const auto small = MissRatioCurve::uniform_reuse(512, 0.9, kL3);
  const auto stream = MissRatioCurve::step(1 << 20, 1.0, 0.0);
  double last_hit = 0.9;
  for (double stream_rate : {0.01, 0.1, 0.4, 1.6}) {
    const double small_rate = 0.01;
    const std::vector<Tenant> both{{&small, small_rate}, {&stream, stream_rate}};
    const std::vector<double> occ = natural_partition(both, kL3, kLine);
    INFO("stream accesses " << stream_rate);
    CHECK(occ[0] + occ[1] == Approx(kL3).epsilon(1e-9));
    // Equal eviction age T: the stream holds a T b (all misses), the small one fp(T).
    const double age = occ[1] / (stream_rate * kLine);
    CHECK(occ[0] == Approx(small.footprint(age, small_rate, kLine)).epsilon(1e-6));
    const double hit = 1 - small.miss_ratio(occ[0]);
    if (stream_rate == 0.01) {
      CHECK(occ[0] > 512);  // a stream as slow as itself leaves it all it reuses
      CHECK(hit == Approx(0.9));
    } else {
      CHECK(occ[0] < 512);
      CHECK(hit < last_hit);  // it loses hits, the more the faster the stream...
      CHECK(hit > 0.0);       // ...but keeps a share
    }
    last_hit = hit;
  }
  // Tenants that fit together keep their working sets, whatever their rates.
  const auto a = MissRatioCurve::step(512, 1.0, 0.0);
  const auto b = MissRatioCurve::step(1024, 1.0, 0.0);
  const std::vector<Tenant> fit{{&a, 0.001}, {&b, 5.0}};
  const std::vector<double> occ = natural_partition(fit, kL3, kLine);
  CHECK(occ[0] == 512);
  CHECK(occ[1] == 1024);
  // A tenant that accesses nothing holds nothing.
  const std::vector<Tenant> idle{{&a, 0.0}, {&stream, 1.0}};
  CHECK(natural_partition(idle, kL3, kLine)[0] == 0.0);
}

TEST_CASE("a further LRU level sees the accesses that miss before it", "[cache]") {
  // capacity_for: the smallest share with a miss ratio, its inverse where the curve falls.
  const auto m = MissRatioCurve::from_points({{0, 1.0}, {1000, 0.5}, {2000, 0.25}});
  CHECK(m.capacity_for(1.0) == 0.0);
  CHECK(m.capacity_for(0.75) == Approx(500.0));
  CHECK(m.capacity_for(0.5) == Approx(1000.0));
  CHECK(m.capacity_for(0.3) == Approx(1800.0));
  CHECK(m.capacity_for(0.1) == 2000.0);  // never that low: the last point
  CHECK(m.miss_ratio(m.capacity_for(0.4)) == Approx(0.4));
  const auto s = MissRatioCurve::step(1792, 1.0, 0.0);
  CHECK(s.capacity_for(1.0) == 0.0);  // a cyclic stream that misses always holds no reuse
  CHECK(s.capacity_for(0.0) == 1792.0);

  // beyond: m'(x) = m(kb + x) / m(kb); the shares add up as one LRU stack.
  const auto b = m.beyond(1000);
  CHECK(b.miss_ratio(0) == 1.0);
  CHECK(b.miss_ratio(500) == Approx(m.miss_ratio(1500) / 0.5));
  CHECK(b.miss_ratio(1000) == Approx(0.5));
  CHECK(b.miss_ratio(5000) == Approx(0.5));
  for (double x : {0.0, 100.0, 700.0, 1500.0})
    CHECK(m.miss_ratio(1000) * b.miss_ratio(x) == Approx(m.miss_ratio(1000 + x)));
  // A stream of 1792 KB that misses in a smaller share hits in a further level of 1792 KB.
  const auto past = s.beyond(s.capacity_for(1.0));
  CHECK(past.miss_ratio(1791) == 1.0);
  CHECK(past.miss_ratio(1792) == 0.0);
  CHECK(past.saturation_kb() == 1792.0);
  // Nothing misses at its saturation: nothing reaches the next level.
  CHECK(s.beyond(1792).miss_ratio(0) == 0.0);
  CHECK(s.beyond(1792).saturation_kb() == 0.0);

  // Two such streams share a further level of 4096 KB: both fit and hit; of 2048 KB they thrash.
  const std::vector<Tenant> two{{&past, 1.0}, {&past, 1.0}};
  for (double occ : natural_partition(two, 4096, kLine))
    CHECK(past.miss_ratio(occ) == 0.0);
  for (double occ : natural_partition(two, 2048, kLine))
    CHECK(past.miss_ratio(occ) == 1.0);
}

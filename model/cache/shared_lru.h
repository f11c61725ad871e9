// A shared LRU cache from its tenants' reuse: miss-ratio curves and the natural partition.
//
// MissRatioCurve: the fraction of a tenant's accesses that miss in a fully associative LRU cache
// of each capacity (Mattson: the accesses whose stack distance exceeds it). Piecewise linear
// between its points, m(0) = 1, constant beyond the last point; monotone non-increasing (a
// measured curve is made so by a running minimum). Two points at one capacity make a step
// (right-continuous: a cache of exactly W KB holds a working set of W KB).
//
// Shared LRU (the footprint / HOTL model: Xiang, Ding et al., "HOTL: a Higher Order Theory of
// Locality", ASPLOS 2013, and "All-window profiling and composable models of cache sharing",
// PPoPP 2011): a tenant accessing the cache at a rate a (accesses per unit time), of which the
// fraction m(c) miss when it holds c, inserts a * m(c) lines per unit time; under LRU a line
// leaves the cache once it has gone unused for the cache's eviction age T, the same for every
// tenant. So a tenant's occupancy after time t grows as dc/dt = a * line * m(c) (its footprint
// fp(t)), and in the steady state of a shared cache of capacity C every tenant holds its
// footprint at the common age T:
//     c_i = fp_i(T),  t_i(c) = integral_0^c dx / (a_i * line * m_i(x)),  sum_i c_i = C
// (natural partition). A tenant whose curve reaches 0 at W saturates at W (all of its lines
// reused before they age out); when the saturations fit, each holds its own. Each then misses
// m_i(c_i): a stream larger than the cache misses always, two streams that together exceed it
// hold less than their working sets each and miss always, and a small footprint beside a stream
// keeps the share its insertion rate earns at the common age.
//
// Contract: pure C++ (no SystemC, no OS calls); deterministic; immutable values.
#pragma once

#include <span>
#include <string>
#include <utility>
#include <vector>

namespace rosguard::cache {

class MissRatioCurve {
 public:
  struct Point {
    double kb = 0.0;
    double miss = 1.0;
  };

  MissRatioCurve() = default;  // m(c) = 1 everywhere: nothing is reused
  // From measured points (any order, kb > 0, miss in [0, 1]); a point at 0 KB is taken as given,
  // else (0, 1) is prepended. Non-increasing by a running minimum. Throws std::invalid_argument
  // for a negative capacity or a ratio outside [0, 1].
  static MissRatioCurve from_points(std::vector<Point> points);
  // A cyclic stream over `working_set_kb` (a built-in kernel: every line touched once per pass,
  // so under LRU each reuse has stack distance exactly the working set): `below` for caches
  // smaller than the working set, `above` from it on.
  static MissRatioCurve step(double working_set_kb, double below, double above);
  // The documented default for a profile with only a footprint F and a hit ratio h measured at
  // capacity C (docs/design.md, "The shared L3"): the hits are reuses whose stack distances are
  // spread uniformly up to a horizon D, the rest never reused:
  //     m(c) = 1 - r * min(1, c / D),  with m(C) = 1 - h:
  //     F <= C:                  D = F,      r = h
  //     F > C and h <= C / F:    D = F,      r = h * F / C
  //     F > C and h > C / F:     D = C / h,  r = 1   (more hits than uniform distances up to F
  //     give)
  static MissRatioCurve uniform_reuse(double footprint_kb, double hit, double capacity_kb);

  double miss_ratio(double kb) const;
  // The smallest capacity at which the curve's miss ratio is at most `miss` (0 for miss >= 1;
  // the last point's capacity when the curve never gets that low): the share that gives a tenant
  // that miss ratio, counting no lines it holds without reuse.
  double capacity_for(double miss) const;
  // The curve of the accesses that miss at `kb` (those whose stack distance exceeds it), as seen
  // by a further LRU level that they feed: m'(x) = m(kb + x) / m(kb). A tenant that misses
  // nowhere at `kb` (m(kb) = 0) sends it nothing: m' = 0.
  MissRatioCurve beyond(double kb) const;
  // Time to grow from 0 to `kb` KB at `accesses` accesses per unit time of `line_kb` each
  // (t(c) above); +inf when the curve reaches 0 before `kb` or accesses is 0.
  double fill_time(double kb, double accesses, double line_kb) const;
  // The occupancy after time `t` (the inverse of fill_time): the footprint fp(t).
  double footprint(double t, double accesses, double line_kb) const;
  // Where the occupancy stops growing: the first capacity where m reaches 0 (+inf if never).
  double saturation_kb() const;
  const std::vector<Point>& points() const { return points_; }
  bool operator==(const MissRatioCurve&) const = default;

 private:
  std::vector<Point> points_{{0.0, 1.0}};
};

// One tenant of a shared cache: its curve and its accesses per unit time (0: it inserts
// nothing and holds nothing in the steady state).
struct Tenant {
  const MissRatioCurve* mrc = nullptr;
  double accesses = 0.0;
};

// The natural partition of a shared LRU cache of `capacity_kb` with lines of `line_kb`:
// occupancy per tenant (KB), summing to the capacity, or to the saturations where they fit.
std::vector<double> natural_partition(std::span<const Tenant> tenants, double capacity_kb,
                                      double line_kb);

}  // namespace rosguard::cache

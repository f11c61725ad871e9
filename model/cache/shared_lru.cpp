#include "cache/shared_lru.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace rosguard::cache {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Time (in KB at miss ratio 1) to grow from k0 to x on a linear piece from (k0, m0) to (k1, m1).
double piece_time(double k0, double m0, double k1, double m1, double x) {
  if (x <= k0) return 0.0;
  if (m0 <= 0.0) return kInf;
  if (m0 == m1) return (x - k0) / m0;
  const double s = (m1 - m0) / (k1 - k0);
  const double mx = m0 + s * (x - k0);
  if (mx <= 0.0) return kInf;
  return std::log(mx / m0) / s;
}

// Where the occupancy is after `tau` on that piece (tau below the piece's whole time).
double piece_at(double k0, double m0, double k1, double m1, double tau) {
  if (m0 == m1) return k0 + tau * m0;
  const double s = (m1 - m0) / (k1 - k0);
  return std::min(k1, k0 + m0 * std::expm1(s * tau) / s);
}

}  // namespace

MissRatioCurve MissRatioCurve::from_points(std::vector<Point> points) {
  for (const Point& p : points) {
    if (!(p.kb >= 0.0) || !std::isfinite(p.kb))
      throw std::invalid_argument("miss-ratio curve: capacity must be finite and >= 0");
    if (!(p.miss >= 0.0 && p.miss <= 1.0))
      throw std::invalid_argument("miss-ratio curve: miss ratio must be in [0, 1]");
  }
  std::stable_sort(points.begin(), points.end(),
                   [](const Point& a, const Point& b) { return a.kb < b.kb; });
  if (points.empty() || points.front().kb > 0.0) points.insert(points.begin(), Point{0.0, 1.0});
  for (std::size_t i = 1; i < points.size(); ++i)
    points[i].miss = std::min(points[i].miss, points[i - 1].miss);
  MissRatioCurve c;
  c.points_ = std::move(points);
  return c;
}

MissRatioCurve MissRatioCurve::step(double working_set_kb, double below, double above) {
  return from_points({{0.0, below}, {working_set_kb, below}, {working_set_kb, above}});
}

MissRatioCurve MissRatioCurve::uniform_reuse(double footprint_kb, double hit, double capacity_kb) {
  hit = std::clamp(hit, 0.0, 1.0);
  double horizon = footprint_kb, reused = hit;
  if (footprint_kb > capacity_kb) {
    if (hit * footprint_kb <= capacity_kb) {
      reused = hit * footprint_kb / capacity_kb;
    } else {
      reused = 1.0;
      horizon = capacity_kb / hit;
    }
  }
  if (!(horizon > 0.0)) return from_points({{0.0, 1.0 - reused}});
  return from_points({{0.0, 1.0}, {horizon, 1.0 - reused}});
}

double MissRatioCurve::miss_ratio(double kb) const {
  const auto it = std::upper_bound(points_.begin(), points_.end(), kb,
                                   [](double k, const Point& p) { return k < p.kb; });
  if (it == points_.begin()) return points_.front().miss;
  const Point& a = *(it - 1);
  if (it == points_.end()) return a.miss;
  const Point& b = *it;
  return a.miss + (b.miss - a.miss) * (kb - a.kb) / (b.kb - a.kb);
}

double MissRatioCurve::capacity_for(double miss) const {
  if (points_.front().miss <= miss) return points_.front().kb;
  for (std::size_t i = 1; i < points_.size(); ++i) {
    const Point& a = points_[i - 1];
    const Point& b = points_[i];
    if (b.miss > miss) continue;
    if (b.kb == a.kb || a.miss == b.miss) return b.kb;
    return a.kb + (b.kb - a.kb) * (a.miss - miss) / (a.miss - b.miss);
  }
  return points_.back().kb;
}

MissRatioCurve MissRatioCurve::beyond(double kb) const {
  const double at = miss_ratio(kb);
  if (!(at > 0.0)) return from_points({{0.0, 0.0}});
  std::vector<Point> shifted{{0.0, 1.0}};
  for (const Point& p : points_)
    if (p.kb > kb) shifted.push_back({p.kb - kb, std::min(1.0, p.miss / at)});
  return from_points(std::move(shifted));
}

double MissRatioCurve::fill_time(double kb, double accesses, double line_kb) const {
  if (kb <= 0.0) return 0.0;
  if (!(accesses > 0.0) || !(line_kb > 0.0)) return kInf;
  double tau = 0.0;
  for (std::size_t i = 0; i + 1 < points_.size(); ++i) {
    const Point& a = points_[i];
    const Point& b = points_[i + 1];
    if (b.kb == a.kb) continue;  // a step: no time
    tau += piece_time(a.kb, a.miss, b.kb, b.miss, std::min(kb, b.kb));
    if (kb <= b.kb || !std::isfinite(tau)) return tau / (accesses * line_kb);
  }
  const Point& last = points_.back();
  tau += last.miss > 0.0 ? (kb - last.kb) / last.miss : kInf;
  return tau / (accesses * line_kb);
}

double MissRatioCurve::footprint(double t, double accesses, double line_kb) const {
  if (!(t > 0.0) || !(accesses > 0.0) || !(line_kb > 0.0)) return 0.0;
  double tau = t * accesses * line_kb;
  for (std::size_t i = 0; i + 1 < points_.size(); ++i) {
    const Point& a = points_[i];
    const Point& b = points_[i + 1];
    if (a.miss <= 0.0) return a.kb;
    if (b.kb == a.kb) continue;
    const double whole = piece_time(a.kb, a.miss, b.kb, b.miss, b.kb);
    if (tau < whole) return piece_at(a.kb, a.miss, b.kb, b.miss, tau);
    tau -= whole;
  }
  const Point& last = points_.back();
  if (last.miss <= 0.0) return last.kb;
  return std::isfinite(tau) ? last.kb + tau * last.miss : kInf;
}

double MissRatioCurve::saturation_kb() const {
  for (const Point& p : points_)
    if (p.miss <= 0.0) return p.kb;
  return kInf;
}

std::vector<double> natural_partition(std::span<const Tenant> tenants, double capacity_kb,
                                      double line_kb) {
  std::vector<double> occ(tenants.size(), 0.0);
  double saturated = 0.0, rate = 0.0;
  for (const Tenant& t : tenants)
    if (t.mrc && t.accesses > 0.0) {
      saturated += t.mrc->saturation_kb();
      rate += t.accesses;
    }
  if (rate <= 0.0) return occ;
  if (saturated <= capacity_kb) {  // every tenant's reused lines fit: each holds its own
    for (std::size_t i = 0; i < tenants.size(); ++i)
      if (tenants[i].mrc && tenants[i].accesses > 0.0) occ[i] = tenants[i].mrc->saturation_kb();
    return occ;
  }
  const auto held = [&](double age) {
    double sum = 0.0;
    for (std::size_t i = 0; i < tenants.size(); ++i)
      if (tenants[i].mrc && tenants[i].accesses > 0.0)
        sum += (occ[i] = tenants[i].mrc->footprint(age, tenants[i].accesses, line_kb));
    return sum;
  };
  // The common eviction age: the footprints are increasing in it, and some grows without bound.
  double lo = 0.0, hi = capacity_kb / (rate * line_kb);  // every access a miss fills it by then
  while (held(hi) < capacity_kb) {
    lo = hi;
    hi *= 2.0;
  }
  for (int i = 0; i < 200 && hi - lo > 1e-13 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (held(mid) < capacity_kb ? lo : hi) = mid;
  }
  held(hi);
  // The bisection leaves the sum within ~1e-13 of the capacity; the last tenant that still grows
  // at that age takes the rest, so that the occupancies add up to the capacity exactly.
  for (std::size_t i = tenants.size(); i-- > 0;)
    if (tenants[i].mrc && tenants[i].accesses > 0.0 && occ[i] < tenants[i].mrc->saturation_kb()) {
      double others = 0.0;
      for (std::size_t j = 0; j < tenants.size(); ++j)
        if (j != i) others += occ[j];
      occ[i] = std::max(0.0, capacity_kb - others);
      break;
    }
  return occ;
}

}  // namespace rosguard::cache

#include "nodes/costs.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/hash.h"

namespace rosguard::sim {

std::uint64_t stream_seed(std::uint64_t run_seed, std::string_view stream) {
  std::uint64_t z = run_seed ^ fnv1a(stream);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

double CostStream::uniform01() {
  return static_cast<double>(rng_() >> 11) * 0x1.0p-53;
}

double CostStream::normal01() {
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  const double u1 = 1.0 - uniform01();  // (0, 1]
  const double u2 = uniform01();
  const double r = std::sqrt(-2.0 * std::log(u1));
  spare_ = r * std::sin(2.0 * std::numbers::pi * u2);
  has_spare_ = true;
  return r * std::cos(2.0 * std::numbers::pi * u2);
}

double CostStream::draw_us() {
  using Kind = Distribution::Kind;
  const Distribution& d = dist_;
  switch (d.kind) {
    case Kind::Constant:
      return d.value_us;
    case Kind::Uniform:
      return d.min_us + (d.max_us - d.min_us) * uniform01();
    case Kind::Normal: {
      // Truncated normal by rejection; a pathological truncation falls back to clamping.
      const double hi = d.max_us >= 0 ? d.max_us : HUGE_VAL;
      for (int attempt = 0; attempt < 32; ++attempt) {
        const double v = d.mean_us + d.spread * normal01();
        if (v >= d.min_us && v <= hi) return v;
      }
      return std::clamp(d.mean_us, d.min_us, hi);
    }
    case Kind::Lognormal: {
      const double v = d.min_us + (d.mean_us - d.min_us) * std::exp(d.spread * normal01());
      return d.max_us >= 0 ? std::min(v, d.max_us) : v;
    }
  }
  return 0.0;
}

TimeNs CostStream::draw_ns() {
  return std::max<TimeNs>(1, static_cast<TimeNs>(std::llround(draw_us() * 1e3)));
}

}  // namespace rosguard::sim

#include "results/precision.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "results/results.h"

namespace rosguard {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace

double student_t95(int df) {
  if (df < 1) throw ContractError("student_t95: degrees of freedom must be >= 1");
  // t_{0.975, df} for df = 1 .. 30.
  static constexpr std::array<double, 30> kTable = {
      12.7062, 4.3027, 3.1824, 2.7764, 2.5706, 2.4469, 2.3646, 2.3060, 2.2622, 2.2281,
      2.2010,  2.1788, 2.1604, 2.1448, 2.1314, 2.1199, 2.1098, 2.1009, 2.0930, 2.0860,
      2.0796,  2.0739, 2.0687, 2.0639, 2.0595, 2.0555, 2.0518, 2.0484, 2.0452, 2.0423};
  if (df <= 30) return kTable[static_cast<std::size_t>(df - 1)];
  // Cornish-Fisher expansion of t around the normal quantile z (Abramowitz & Stegun 26.7.5).
  const double z = 1.959963984540054;
  const double z3 = z * z * z, z5 = z3 * z * z, z7 = z5 * z * z;
  const double n = df;
  return z + (z3 + z) / (4 * n) + (5 * z5 + 16 * z3 + 3 * z) / (96 * n * n) +
         (3 * z7 + 19 * z5 + 17 * z3 - 15 * z) / (384 * n * n * n);
}

double MeanCi::half_width_pct() const {
  if (n < 2 || !std::isfinite(half_width) || !std::isfinite(mean) || mean == 0.0) return kNaN;
  return 100.0 * half_width / std::fabs(mean);
}

MeanCi mean_ci95(const std::vector<double>& values) {
  MeanCi ci;
  double sum = 0.0;
  for (double v : values)
    if (std::isfinite(v)) {
      sum += v;
      ++ci.n;
    }
  if (ci.n == 0) {
    ci.mean = kNaN;
    ci.half_width = kNaN;
    return ci;
  }
  ci.mean = sum / ci.n;
  if (ci.n < 2) {
    ci.half_width = kNaN;
    return ci;
  }
  double ss = 0.0;
  for (double v : values)
    if (std::isfinite(v)) ss += (v - ci.mean) * (v - ci.mean);
  const double s = std::sqrt(ss / (ci.n - 1));
  ci.half_width = student_t95(ci.n - 1) * s / std::sqrt(static_cast<double>(ci.n));
  return ci;
}

double round_baseline_us(const BaselineRuns& runs, int round, const RoundPairing& pairing) {
  std::vector<double> of_round, all;
  for (const auto& [k, r] : runs.runs) {
    all.push_back(r.time_us);
    const int before = pairing.one_per_round ? k
                                             : baseline_round(k, std::max(1, pairing.repetitions),
                                                              std::max(1, pairing.measurements));
    if (before == round) of_round.push_back(r.time_us);
  }
  const double m = finite_median(of_round);
  return std::isfinite(m) ? m : finite_median(all);
}

std::vector<MeanCi> slowdown_cis(const std::vector<const BaselineRuns*>& baselines,
                                 const std::map<int, std::vector<double>>& times,
                                 const RoundPairing& pairing) {
  std::vector<MeanCi> out;
  for (std::size_t node = 0; node < baselines.size(); ++node) {
    std::vector<double> ratios;
    if (baselines[node])
      for (const auto& [round, t] : times) {
        if (node >= t.size()) continue;
        ratios.push_back(t[node] / round_baseline_us(*baselines[node], round, pairing));
      }
    out.push_back(mean_ci95(ratios));
  }
  return out;
}

PrecisionRule precision_rule(int repetitions, std::optional<double> precision_pct,
                             int max_repetitions) {
  PrecisionRule r;
  r.target_pct = precision_pct;
  if (!precision_pct) {
    r.min_rounds = r.max_rounds = std::max(1, repetitions);
    return r;
  }
  r.max_rounds = std::max({1, repetitions, max_repetitions});
  r.min_rounds = std::min(r.max_rounds, std::max(repetitions, kMinAdaptiveRounds));
  return r;
}

RoundsVerdict judge_rounds(const PrecisionRule& rule, int rounds, const std::vector<MeanCi>& cis) {
  if (rounds < rule.min_rounds) return RoundsVerdict::More;
  if (!rule.target_pct) return RoundsVerdict::Fixed;
  const bool within = std::all_of(cis.begin(), cis.end(), [&](const MeanCi& ci) {
    if (ci.n == 0) return true;  // a slowdown this point does not have
    const double pct = ci.half_width_pct();
    return std::isfinite(pct) && pct <= *rule.target_pct;
  });
  if (within) return RoundsVerdict::Precise;
  return rounds >= rule.max_rounds ? RoundsVerdict::Capped : RoundsVerdict::More;
}

std::string_view to_string(RoundsVerdict v) {
  switch (v) {
    case RoundsVerdict::More:
      return "more";
    case RoundsVerdict::Precise:
      return "precise";
    case RoundsVerdict::Capped:
      return "capped";
    case RoundsVerdict::Fixed:
      return "fixed";
  }
  return "?";
}

double widest_ci_pct(const std::vector<MeanCi>& cis) {
  double w = kNaN;
  for (const auto& ci : cis) {
    const double pct = ci.half_width_pct();
    if (ci.n > 0 && std::isfinite(pct) && (std::isnan(w) || pct > w)) w = pct;
  }
  return w;
}

}  // namespace rosguard

// How precisely a point's slowdowns are known, and when to stop repeating it (docs/design.md,
// section 5: hw.precision_pct and hw.max_repetitions).
//
// A point runs in rounds; before each round its isolation baselines are measured (hw), so a
// round gives one slowdown per node: its co-run time over the baseline of the same round. The
// precision of a slowdown is the half-width of the 95 % confidence interval (Student t) of the
// mean of those per-round ratios, in percent of the mean. The runner stops repeating a point
// once every slowdown it has is within the target, or at the cap.
//
// Contract: pure functions (no clock, no OS); NaN is "not measured" as everywhere in results.
#pragma once

#include <map>
#include <optional>
#include <string_view>
#include <vector>

#include "backend/backend.h"

namespace rosguard {

// The two-sided 95 % quantile of Student's t distribution with `df` degrees of freedom
// (t_{0.975, df}): a table to df 30, then the Cornish-Fisher expansion (error below 1e-4).
// Throws ContractError for df < 1.
double student_t95(int df);

// The mean of a sample and the 95 % confidence interval of that mean.
struct MeanCi {
  int n = 0;              // finite values used
  double mean = 0.0;      // NaN when n == 0
  double half_width = 0;  // t_{0.975, n-1} x s / sqrt(n); NaN when n < 2
  // 100 x half_width / |mean|: the precision in percent; NaN when n < 2 or the mean is 0.
  double half_width_pct() const;
};
// NaN values are left out.
MeanCi mean_ci95(const std::vector<double>& values);

// Which baseline measurements were taken before repetition round r.
struct RoundPairing {
  // The fixed plan (docs/design.md, section 5): measurement k of `measurements` runs before
  // round baseline_round(k, repetitions, measurements).
  int repetitions = 1;
  int measurements = 1;
  // Adaptive rounds (hw.precision_pct): measurement r runs before round r.
  bool one_per_round = false;
};

// Adjacent baselines (hw.adjacent_baselines): measurement r of a point's own baseline was taken
// right before its repetition r.
inline RoundPairing adjacent_pairing() {
  RoundPairing p;
  p.one_per_round = true;
  return p;
}

// The isolation time of round `round` of a baseline: the median of the measurements taken
// before that round, or the median of all of them when none was (sim: one measurement before
// round 0; a folder resumed with fewer baseline measurements). NaN when there is none.
double round_baseline_us(const BaselineRuns& runs, int round, const RoundPairing& pairing);

// One CI per node of a point (its RT nodes, then its nRT nodes, in scenario order) over the
// per-round slowdowns time / round_baseline_us(round). `times`: by repetition (= round), the
// nodes' co-run times in that order (NaN: not measured); `baselines`: each node's baseline
// (null: missing, that node's CI then has n = 0).
std::vector<MeanCi> slowdown_cis(const std::vector<const BaselineRuns*>& baselines,
                                 const std::map<int, std::vector<double>>& times,
                                 const RoundPairing& pairing);

// How many rounds a point runs.
struct PrecisionRule {
  std::optional<double> target_pct;  // absent: exactly min_rounds (= max_rounds)
  int min_rounds = 1;
  int max_rounds = 1;
};

// The fewest rounds an adaptive point runs before its CI is judged: two values give a CI whose
// t factor is 12.7 and whose spread is one difference, which a lucky pair can make look tight.
inline constexpr int kMinAdaptiveRounds = 3;

// From the scenario: fixed: `repetitions` rounds; with a target: at least
// max(repetitions, kMinAdaptiveRounds) rounds (at most the cap), at most `max_repetitions`.
PrecisionRule precision_rule(int repetitions, std::optional<double> precision_pct,
                             int max_repetitions);

enum class RoundsVerdict {
  More,     // run another round
  Precise,  // every slowdown's CI is within the target
  Capped,   // the cap came first
  Fixed,    // no target: the fixed rounds are done
};

// The stopping rule after `rounds` rounds whose CIs are `cis` (slowdown_cis): a CI with n == 0
// (a slowdown the point does not have, such as the RT slowdown of a point without RT node) is
// not judged; one that cannot be computed (n < 2, mean 0) is not within the target. A point
// without any slowdown to judge is Precise once it has min_rounds.
RoundsVerdict judge_rounds(const PrecisionRule& rule, int rounds, const std::vector<MeanCi>& cis);

std::string_view to_string(RoundsVerdict v);

// The widest precision (half_width_pct) among `cis` with n > 0; NaN when none is finite.
double widest_ci_pct(const std::vector<MeanCi>& cis);

}  // namespace rosguard

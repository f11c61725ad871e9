// ThresholdSearch (tools/rosguard/tune/tune.h), the search behind `rosguard tune`: on a monotone
// ladder it bisects to the highest rung that meets the bound in about log2(rungs) probes; a
// probe that contradicts monotonicity makes it scan, and the pick is then the best rung
// whatever its place.
#include <catch2/catch.hpp>
#include <cmath>
#include <functional>
#include <limits>
#include <vector>

#include "core/error.h"
#include "tune/tune.h"

using namespace rosguard;

namespace {

constexpr double kBound = 1.2;

struct Run {
  std::optional<int> pick;
  int probes = 0;
  int batches = 0;
  std::string contradiction;
  bool scanned = false;
};

// Drives a search to its end with rt(rung), nrt(rung) as the "simulation".
Run drive(int rungs, const std::function<double(int)>& rt, const std::function<double(int)>& nrt) {
  ThresholdSearch s(rungs);
  Run out;
  for (int guard = 0; guard < 100; ++guard) {
    const std::vector<int> next = s.next();
    if (next.empty()) break;
    ++out.batches;
    for (int r : next) {
      REQUIRE_FALSE(s.probes().count(r));  // never the same rung twice
      s.record(r, {rt(r), nrt(r), rt(r) <= kBound});
      ++out.probes;
    }
    const std::string why = s.update([](int r) { return "rung " + std::to_string(r); });
    if (!why.empty()) out.contradiction = why;
  }
  out.pick = s.pick();
  out.scanned = s.scanned();
  return out;
}

double rising(int r) {
  return 1.0 + 0.05 * r;
}  // RT slowdown: 1.0, 1.05, ... (> 1.2 at 5)
double falling(int r) {
  return 10.0 / (1.0 + r);
}  // nRT slowdown

}  // namespace

TEST_CASE("tune search: a monotone ladder is bisected to the highest rung within the bound",
          "[tune]") {
  const Run run = drive(17, rising, falling);
  REQUIRE(run.pick);
  CHECK(*run.pick == 4);  // 1.20 at rung 4, 1.25 at rung 5
  CHECK_FALSE(run.scanned);
  CHECK(run.contradiction.empty());
  // ceil(log2(18)) = 5 bisection probes, at most one more below the pick: well below 17.
  CHECK(run.probes <= 6);
  CHECK(run.batches == run.probes);  // one probe per batch per configuration
}

TEST_CASE("tune search: every rung within the bound picks the top, none picks nothing", "[tune]") {
  const Run all = drive(
      17, [](int) { return 1.01; }, falling);
  REQUIRE(all.pick);
  CHECK(*all.pick == 16);
  CHECK(all.probes <= 6);
  const Run none = drive(
      17, [](int r) { return 1.5 + 0.01 * r; }, falling);
  CHECK_FALSE(none.pick);
  CHECK(none.probes <= 5);
  const Run one = drive(1, rising, falling);
  REQUIRE(one.pick);
  CHECK(*one.pick == 0);
}

TEST_CASE("tune search: an RT slowdown that falls as the threshold rises makes it scan", "[tune]") {
  // Dips at rungs 8 and 11 (RT slowdown 1.1, within the bound) although rungs 5..7, 9, 10 are
  // not. Bisection probes 8 (within), 12, 10, 9 (not), then the rung below its pick, 7, whose
  // RT slowdown 1.35 is above rung 8's: the contradiction makes it scan, which finds rung 11.
  const auto rt = [](int r) { return r == 8 || r == 11 ? 1.1 : rising(r); };
  const Run run = drive(17, rt, falling);
  CHECK(run.scanned);
  CHECK(run.contradiction.find("RT slowdown") != std::string::npos);
  CHECK(run.probes == 17);  // every rung, each once
  REQUIRE(run.pick);
  CHECK(*run.pick == 11);
}

TEST_CASE("tune search: an nRT slowdown that rises within the bound makes it scan", "[tune]") {
  // Within the bound (rungs 0..4) nRT slowdown is lowest at rung 3, not at the top rung 4.
  const auto nrt = [](int r) { return r == 3 ? 1.0 : falling(r); };
  const Run run = drive(17, rising, nrt);
  CHECK(run.scanned);
  CHECK(run.contradiction.find("nRT slowdown") != std::string::npos);
  REQUIRE(run.pick);
  CHECK(*run.pick == 3);
}

TEST_CASE("tune search: wiggles within the tolerance are not contradictions", "[tune]") {
  // RT slowdown flat at 1.0 with +-0.3 % noise; nRT slowdown falling with the same noise.
  const auto rt = [](int r) { return 1.0 + (r % 2 ? 0.003 : -0.003); };
  const auto nrt = [](int r) { return falling(r) * (r % 2 ? 1.003 : 0.997); };
  const Run run = drive(17, rt, nrt);
  CHECK_FALSE(run.scanned);
  REQUIRE(run.pick);
  CHECK(*run.pick == 16);
}

TEST_CASE("tune search: an unmeasured RT slowdown never meets the bound", "[tune]") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const Run run = drive(
      8, [&](int) { return nan; }, falling);
  CHECK_FALSE(run.pick);
  CHECK_THROWS_AS(ThresholdSearch(0), ContractError);
}

// The cache models behind `rosguard profile` (model/profile/): set-associative LRU, the private
// L1 + L2, Mattson stack distances, the profiler's slices, MRC and phases, lackey's trace lines.
#include <catch2/catch.hpp>
#include <cstdint>
#include <list>
#include <random>
#include <vector>

#include "core/error.h"
#include "profile/cache_model.h"
#include "profile/profiler.h"

using namespace rosguard::profile;

namespace {

// Misses of `passes` cyclic sweeps over `lines` lines.
std::uint64_t sweep_misses(LruCache& cache, std::uint64_t lines, int passes, bool write = false,
                           std::uint64_t* writebacks = nullptr) {
  std::uint64_t misses = 0;
  for (int p = 0; p < passes; ++p)
    for (std::uint64_t l = 0; l < lines; ++l) {
      const auto r = cache.access(l, write);
      misses += !r.hit;
      if (writebacks) *writebacks += r.evicted_dirty;
    }
  return misses;
}

// The stack distance by definition: distinct lines since the last access (a list, O(n)).
struct NaiveStack {
  std::list<std::uint64_t> stack;  // most recent first
  std::uint64_t access(std::uint64_t line) {
    std::uint64_t d = 0;
    for (auto it = stack.begin(); it != stack.end(); ++it, ++d)
      if (*it == line) {
        stack.erase(it);
        stack.push_front(line);
        return d;
      }
    stack.push_front(line);
    return StackDistance::kFirstTouch;
  }
};

}  // namespace

TEST_CASE("LRU cache: a cyclic stream larger than the cache misses on every access") {
  LruCache cache({4096, 4, 64});              // 64 lines, 16 sets
  CHECK(sweep_misses(cache, 80, 10) == 800);  // five lines per 4-way set: LRU thrashes
  LruCache big({4096, 4, 64});
  CHECK(sweep_misses(big, 128, 10) == 1280);
}

TEST_CASE("LRU cache: a loop that fits misses only while it warms up") {
  LruCache cache({4096, 4, 64});
  CHECK(sweep_misses(cache, 64, 1) == 64);
  CHECK(sweep_misses(cache, 64, 9) == 0);
  LruCache half({4096, 4, 64});
  CHECK(sweep_misses(half, 32, 10) == 32);
}

TEST_CASE("LRU cache: dirty victims are write-backs, clean ones are not") {
  LruCache cache({4096, 4, 64});
  std::uint64_t wb = 0;
  sweep_misses(cache, 128, 2, /*write=*/false, &wb);
  CHECK(wb == 0);
  LruCache dirty({4096, 4, 64});
  sweep_misses(dirty, 128, 2, /*write=*/true, &wb);
  CHECK(wb == 256 - 64);  // every miss after the first 64 evicts a dirty line
}

TEST_CASE("LRU cache: a set keeps its most recently used lines") {
  LruCache cache({2 * 64, 2, 64});  // one set of two ways
  cache.access(1, false);
  cache.access(2, false);
  cache.access(1, false);  // 2 is now the LRU
  const auto r = cache.access(3, false);
  CHECK(r.evicted);
  CHECK(r.victim == 2);
  CHECK(cache.access(1, false).hit);
}

TEST_CASE("LRU cache: a geometry that is not whole sets is refused") {
  CHECK_THROWS_AS(LruCache({1000, 4, 64}), rosguard::InputError);
  CHECK_THROWS_AS(LruCache({4096, 4, 48}), rosguard::InputError);
  CHECK_THROWS_AS(LruCache({4096, 0, 64}), rosguard::InputError);
}

TEST_CASE("Private L1 + L2: a stream beyond the L2 refills once per line, a loop in L2 does not") {
  PrivateHierarchy h({64 * 64, 4, 64}, {256 * 64, 8, 64});  // 64-line L1, 256-line L2
  std::uint64_t l1 = 0, l2 = 0;
  for (int pass = 0; pass < 4; ++pass)
    for (std::uint64_t l = 0; l < 128; ++l) {  // fits the L2, not the L1
      const auto t = h.access(l, false);
      l1 += t.l1_miss;
      l2 += t.l2_refill;
    }
  CHECK(l1 == 4 * 128);
  CHECK(l2 == 128);
  PrivateHierarchy s({64 * 64, 4, 64}, {256 * 64, 8, 64});
  l2 = 0;
  std::uint64_t wb = 0;
  for (int pass = 0; pass < 4; ++pass)
    for (std::uint64_t l = 0; l < 512; ++l) {  // beyond the L2, written
      const auto t = s.access(l, true);
      l2 += t.l2_refill;
      wb += t.writebacks;
    }
  CHECK(l2 == 4 * 512);
  // Every line written is written back once it leaves the L2, except the last L2-full.
  CHECK(wb >= 4 * 512 - 256 - 64);
  CHECK(wb <= 4 * 512);
}

TEST_CASE("Stack distance: known sequences") {
  StackDistance s;
  CHECK(s.access(10) == StackDistance::kFirstTouch);
  CHECK(s.access(10) == 0);
  CHECK(s.access(11) == StackDistance::kFirstTouch);
  CHECK(s.access(12) == StackDistance::kFirstTouch);
  CHECK(s.access(10) == 2);
  CHECK(s.access(12) == 1);
  CHECK(s.access(11) == 2);
  CHECK(s.distinct_lines() == 3);
}

TEST_CASE("Stack distance: equals the definition on a random stream, across renumbering") {
  StackDistance fast;
  NaiveStack naive;
  std::mt19937_64 rng(7);
  std::uniform_int_distribution<std::uint64_t> hot(0, 50), cold(0, 3000);
  // More accesses than the initial tree holds (65536), so renumber() runs several times.
  for (int i = 0; i < 200000; ++i) {
    const std::uint64_t line = (i % 3 == 0) ? cold(rng) : hot(rng);
    const auto expected = naive.access(line);
    const auto got = fast.access(line);
    if (got != expected) {
      FAIL_CHECK("access " << i << " line " << line << ": " << got << " != " << expected);
      break;
    }
  }
}

TEST_CASE("Profiler: slices, MRC monotone, capacities include the L3's") {
  ProfilerConfig c;
  c.l1 = {4096, 4, 64};
  c.l2 = {16384, 8, 64};
  c.l3 = {96 * 1024, 16, 64};  // added to the MRC capacities
  c.slice_instructions = 1000;
  c.mrc_capacities_kb = {32, 64, 128, 256};
  Profiler p(c);
  REQUIRE(p.capacities_kb() == std::vector<std::uint64_t>{32, 64, 96, 128, 256});
  std::mt19937_64 rng(3);
  std::geometric_distribution<std::uint64_t> reuse(0.0005);  // lines, mostly near, some far
  for (int i = 0; i < 200000; ++i) {
    p.instruction();
    p.access(reuse(rng) * 64, 8, i % 4 == 0 ? AccessKind::Store : AccessKind::Load);
  }
  p.finish();
  CHECK(p.instructions() == 200000);
  CHECK(p.slices().size() == 200);
  const SliceCounts t = p.total();
  REQUIRE(t.l2_refills > 0);
  CHECK(t.loads + t.stores == 200000);
  for (std::size_t i = 1; i < t.l3_misses.size(); ++i)
    CHECK(t.l3_misses[i] <= t.l3_misses[i - 1]);
  CHECK(t.l3_misses.front() > t.l3_misses.back());  // the curve is not flat here
  CHECK(t.l3_misses.front() <= t.l2_refills);
  CHECK(t.mlp() >= 1.0);
}

TEST_CASE("Profiler: an access across a line boundary touches both lines") {
  ProfilerConfig c;
  c.slice_instructions = 10;
  Profiler p(c);
  p.instruction();
  p.access(60, 8, AccessKind::Load);
  p.finish();
  CHECK(p.footprint_lines() == 2);
  CHECK(p.total().l1_refills == 2);
  CHECK(p.total().loads == 1);
}

TEST_CASE("Phases: adjacent slices with similar rates merge, different ones do not") {
  const auto slice = [](std::uint64_t refills, std::uint64_t wbs) {
    SliceCounts s;
    s.instructions = 1000000;
    s.l2_refills = refills;
    s.l2_writebacks = wbs;
    s.l3_misses = {refills};
    return s;
  };
  // 20 pki, 21 pki, then 2 pki, 2 pki, then 20 pki again.
  const std::vector<SliceCounts> slices = {slice(20000, 0), slice(21000, 0), slice(2000, 0),
                                           slice(2000, 100), slice(20000, 0)};
  const auto phases = merge_phases(slices);
  REQUIRE(phases.size() == 3);
  CHECK(phases[0].slice_count == 2);
  CHECK(phases[0].counts.l2_refills == 41000);
  CHECK(phases[1].slice_count == 2);
  CHECK(phases[2].first_slice == 4);
  // At most two phases: the tolerances widen until they fit.
  CHECK(merge_phases(slices, 0.25, 0.5, 2).size() <= 2);
  CHECK(merge_phases(slices, 0.25, 0.5, 1).size() == 1);
}

TEST_CASE("lackey trace lines parse and anything else is not an event") {
  const auto i = parse_lackey_line("I  0400d7d4,8");
  REQUIRE(i);
  CHECK(i->kind == TraceEvent::Kind::Instruction);
  CHECK(i->address == 0x400d7d4);
  CHECK(i->size == 8);
  const auto l = parse_lackey_line(" L 1ffefffd10,8");
  REQUIRE(l);
  CHECK(l->kind == TraceEvent::Kind::Load);
  CHECK(l->address == 0x1ffefffd10);
  CHECK(parse_lackey_line(" S 04222cac,4")->kind == TraceEvent::Kind::Store);
  CHECK(parse_lackey_line(" M 0421d7c0,16")->size == 16);
  CHECK_FALSE(parse_lackey_line("==123== Lackey, an example Valgrind tool"));
  CHECK_FALSE(parse_lackey_line(" L zz,8"));
  CHECK_FALSE(parse_lackey_line(" L 0400,"));
  CHECK_FALSE(parse_lackey_line(""));
}

TEST_CASE("Profiler: reset_counts starts counting afresh with the caches kept warm") {
  ProfilerConfig c;
  c.slice_instructions = 100;
  Profiler p(c);
  for (int pass = 0; pass < 2; ++pass)
    for (std::uint64_t a = 0; a < 32 * 1024; a += 64) {  // 32 KB: fits the 64 KB L1
      p.instruction();
      p.access(a, 8, AccessKind::Load);
    }
  REQUIRE(p.total().l1_refills == 512);
  p.reset_counts();
  CHECK(p.instructions() == 0);
  CHECK(p.slices().empty());
  for (std::uint64_t a = 0; a < 32 * 1024; a += 64) {
    p.instruction();
    p.access(a, 8, AccessKind::Load);
  }
  p.finish();
  CHECK(p.instructions() == 512);
  CHECK(p.total().l1_refills == 0);  // warm from before the reset
  CHECK(p.total().loads == 512);
}

TEST_CASE("phases of a long run: slices that alternate are joined before the tolerances grow") {
  // 4000 slices: a first stage alternating between 30 and 5 refills pki slice by slice, then a
  // flat second stage at 1 pki. Widening the tolerances alone made one phase of both stages.
  std::vector<SliceCounts> slices(4000);
  for (std::size_t i = 0; i < slices.size(); ++i) {
    slices[i].instructions = 1000000;
    slices[i].l2_refills = i < 2000 ? (i % 2 ? 5000 : 30000) : 1000;
  }
  const auto phases = merge_phases(slices);
  REQUIRE(phases.size() == 2);
  CHECK(phases[0].first_slice == 0);
  CHECK(phases[0].slice_count == 2000);
  CHECK(phases[0].counts.pki(phases[0].counts.l2_refills) == Approx(17.5));
  CHECK(phases[1].first_slice == 2000);
  CHECK(phases[1].slice_count == 2000);
  CHECK(phases[1].counts.pki(phases[1].counts.l2_refills) == Approx(1.0));
}

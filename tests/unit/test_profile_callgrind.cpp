// callgrind's dumps into the slices of `rosguard profile --tracer callgrind`
// (model/profile/callgrind.h): the summary line by its event names, the L2 run's counts, each
// capacity's misses per slice, a run that did not execute alike, and callgrind's set counts.
#include <catch2/catch.hpp>
#include <string>
#include <vector>

#include "profile/callgrind.h"

using namespace rosguard::profile;

namespace {

// A dump as callgrind 3.19 writes one (--cache-sim=yes --simulate-wb=yes), cost lines cut.
std::string dump_text(int part, const std::string& summary) {
  return "# callgrind format\nversion: 1\ncreator: callgrind-3.19.0\npart: " +
         std::to_string(part) +
         "\n\ndesc: D1 cache: 65536 B, 64 B, 4-way associative\n"
         "events: Ir Dr Dw I1mr D1mr D1mw ILmr DLmr DLmw ILdmr DLdmr DLdmw\n"
         "summary: " +
         summary + "\n\nob=(1) /bin/x\nfn=(0) main\n0 5 1 1\ntotals: 1 2 3\n";
}

CallgrindDump dump(int part, std::uint64_t ir, std::uint64_t l2_misses, std::uint64_t dirty = 0) {
  // Ir Dr Dw I1mr D1mr D1mw ILmr DLmr DLmw ILdmr DLdmr DLdmw
  auto d = parse_callgrind_dump(
      dump_text(part, std::to_string(ir) + " " + std::to_string(ir / 4) + " " +
                          std::to_string(ir / 8) + " 0 " + std::to_string(2 * l2_misses) + " 0 0 " +
                          std::to_string(l2_misses) + " 0 0 " + std::to_string(dirty) + " 0"));
  REQUIRE(d);
  return *d;
}

}  // namespace

TEST_CASE("callgrind dump: part and summary by event name, the first summary line only") {
  const auto d =
      parse_callgrind_dump(dump_text(7, "9259139 2492008 1737358 0 0 1429 0 0 1429 0 0 1429"));
  REQUIRE(d);
  CHECK(d->part == 7);
  CHECK(d->at("Ir") == 9259139);
  CHECK(d->at("Dr") == 2492008);
  CHECK(d->at("D1mw") == 1429);
  CHECK(d->at("DLmw") == 1429);
  CHECK(d->at("DLdmw") == 1429);
  CHECK(d->at("DLdmr") == 0);
  CHECK(d->at("nonesuch") == 0);
  // Trailing zeros may be left out of a summary line.
  const auto short_line = parse_callgrind_dump(dump_text(1, "100 20"));
  REQUIRE(short_line);
  CHECK(short_line->at("Dr") == 20);
  CHECK(short_line->at("DLdmw") == 0);
  CHECK_FALSE(parse_callgrind_dump("version: 1\npart: 1\n"));
  CHECK_FALSE(parse_callgrind_dump("events: Ir\n"));
}

TEST_CASE("callgrind slices: the L2 run's counts, each capacity's misses slice by slice") {
  const std::vector<CallgrindDump> l2 = {dump(1, 1000, 100, 40), dump(2, 2000, 10, 5)};
  const std::vector<CallgrindDump> big = {dump(1, 1000, 60), dump(2, 2000, 10)};
  const std::vector<CallgrindDump> huge = {dump(1, 1000, 0), dump(2, 2000, 1)};
  const CallgrindSlices s = callgrind_slices(l2, {l2, big, huge});
  REQUIRE(s.slices.size() == 2);
  CHECK(s.misaligned.empty());
  CHECK(s.slices[0].instructions == 1000);
  CHECK(s.slices[0].loads == 250);
  CHECK(s.slices[0].stores == 125);
  CHECK(s.slices[0].l1_refills == 200);
  CHECK(s.slices[0].l2_refills == 100);
  CHECK(s.slices[0].l2_writebacks == 40);
  CHECK(s.slices[0].l3_misses == std::vector<std::uint64_t>{100, 60, 0});
  CHECK(s.slices[1].l3_misses == std::vector<std::uint64_t>{10, 10, 1});
  CHECK(s.slices[0].refill_overlap == 0);
}

TEST_CASE("callgrind slices: a run that did not execute alike is spread by L2 refills") {
  const std::vector<CallgrindDump> l2 = {dump(1, 1000, 100), dump(2, 1000, 300)};
  // One dump fewer, and another instruction count: not the same execution.
  const std::vector<CallgrindDump> other = {dump(1, 1500, 200)};
  const CallgrindSlices s = callgrind_slices(l2, {other});
  CHECK(s.misaligned == std::vector<std::size_t>{0});
  // 200 of 400 L2 refills missed: half of each slice's.
  CHECK(s.slices[0].l3_misses[0] == 50);
  CHECK(s.slices[1].l3_misses[0] == 150);
  // Within 1 % per dump counts as the same execution.
  const std::vector<CallgrindDump> close = {dump(1, 1005, 80), dump(2, 995, 30)};
  CHECK(callgrind_slices(l2, {close}).misaligned.empty());
}

TEST_CASE("callgrind ways: a power-of-two set count, the given associativity where it gives one") {
  CHECK(callgrind_ways(256 * 1024, 8, 64) == 8);     // 512 sets
  CHECK(callgrind_ways(2048 * 1024, 16, 64) == 16);  // 2048 sets
  CHECK(callgrind_ways(3072 * 1024, 16, 64) == 12);  // 4096 sets of 12
  CHECK(callgrind_ways(48 * 1024, 8, 64) == 6);      // 128 sets of 6 (an x86 L1d of 48 KB)
  CHECK(callgrind_ways(1000 * 1024, 16, 64) == 0);   // 16000 lines: no power-of-two split
}

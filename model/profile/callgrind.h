// Slices of a program from valgrind's callgrind instead of a memory trace, for
// `rosguard profile --tracer callgrind`: the program runs once per L3 capacity of the MRC, each
// run with callgrind's two-level cache model (D1 = the target's L1, LL = that capacity,
// --simulate-wb) dumping its counts every so many basic blocks. The run whose LL is the
// target's L2 gives each slice's loads, stores, L1 and L2 refills and L2 write-backs; each other
// run gives the slice's misses at its capacity. Every run executes the same basic blocks, so
// dump k of one run covers the same instructions as dump k of another.
//
// No I/O here: the host (tools/rosguard/host/profile.cpp) runs valgrind and reads the files.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "profile/profiler.h"

namespace rosguard::profile {

// One callgrind dump: its part number (1, 2, ...; the dump at the program's end has the
// highest) and its summary counts by event name (Ir, Dr, Dw, D1mr, D1mw, DLmr, DLmw, DLdmr,
// DLdmw, ...).
struct CallgrindDump {
  int part = 0;
  std::map<std::string, std::uint64_t> counts;
  std::uint64_t at(const std::string& event) const;  // 0 when absent
};

// Parses a dump file's text ("part:", "events:" and "summary:" or "totals:" lines); nullopt
// when it has no events or summary line.
std::optional<CallgrindDump> parse_callgrind_dump(std::string_view text);

// The slices of one program from its runs: `l2_run` with LL = the L2, `capacity_runs[i]` with LL
// = capacities_kb[i] (the dumps of each in part order). A capacity equal to the L2's may use the
// L2 run itself. Where a run's dumps do not line up with the L2 run's (another count of dumps,
// or a dump whose instruction count differs by more than 1 %: a program that does not run the
// same way twice), that capacity's misses are spread over the slices in proportion to their
// L2 refills, and `misaligned` lists its index. refill_overlap stays 0 (the counts show no timing).
struct CallgrindSlices {
  std::vector<SliceCounts> slices;
  std::vector<std::size_t> misaligned;
};
CallgrindSlices callgrind_slices(const std::vector<CallgrindDump>& l2_run,
                                 const std::vector<std::vector<CallgrindDump>>& capacity_runs);

// Callgrind accepts a cache whose set count is a power of two: `ways` when that gives one, else
// the nearest associativity (from 1 to 64) that does; 0 when none does.
unsigned callgrind_ways(std::uint64_t size_bytes, unsigned ways, unsigned line_bytes);

}  // namespace rosguard::profile

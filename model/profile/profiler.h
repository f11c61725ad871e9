// The profile of a program from its memory trace, for `rosguard profile`: instructions and data
// accesses go in (in program order), per-slice counts come out, and adjacent slices with similar
// rates are merged into phases (sim/workload/profile.h's shape: refills and write-backs per
// kilo-instruction, with the L2 miss stream's miss-ratio curve over L3 capacities).
//
// Contract: single-threaded; the host (tools/rosguard/host/profile.cpp) parses the trace and calls
// `instruction()` / `access()`; `finish()` once at the end. No I/O here.
#pragma once

#include <cstdint>
#include <deque>
#include <optional>
#include <string_view>
#include <unordered_set>
#include <vector>

#include "profile/cache_model.h"

namespace rosguard::profile {

struct ProfilerConfig {
  CacheGeometry l1{64 * 1024, 4, 64};
  CacheGeometry l2{256 * 1024, 8, 64};
  CacheGeometry l3{2048 * 1024, 16, 64};  // the MRC always includes its capacity
  std::uint64_t slice_instructions = 2'000'000;
  std::vector<std::uint64_t> mrc_capacities_kb{256, 512, 1024, 2048, 4096, 8192};
  // Refills in flight are estimated from the L2 refills within this many instructions of each
  // other (the reorder window: 160 entries on a Cortex-A78).
  std::uint64_t mlp_window_instructions = 160;
};

struct SliceCounts {
  std::uint64_t instructions = 0;
  std::uint64_t loads = 0, stores = 0;  // a modify counts as both
  std::uint64_t l1_refills = 0, l1_writebacks = 0;
  std::uint64_t l2_refills = 0, l2_writebacks = 0;
  // Per MRC capacity: the L2 refills that miss in a fully associative LRU L3 of that size fed
  // the L2 miss stream (refills and write-backs).
  std::vector<std::uint64_t> l3_misses;
  // Sum over L2 refills of the refills within the MLP window before it (itself included).
  std::uint64_t refill_overlap = 0;

  void add(const SliceCounts& o);
  double pki(std::uint64_t count) const {
    return instructions ? 1000.0 * static_cast<double>(count) / static_cast<double>(instructions)
                        : 0.0;
  }
  double mlp() const;
};

enum class AccessKind { Load, Store, Modify };

class Profiler {
 public:
  explicit Profiler(ProfilerConfig config);

  void instruction();
  // `size` bytes at `address`; an access across a line boundary touches both lines.
  void access(std::uint64_t address, std::uint64_t size, AccessKind kind);
  void finish();
  // Starts counting afresh (slices, instructions, footprint) with the caches and the L3 stack
  // as they are: what ran before warmed them. Footprint then counts the lines that miss the L1
  // from here on (lines still in the L1 at the reset are not counted until they leave it).
  void reset_counts();

  const ProfilerConfig& config() const { return config_; }
  // MRC capacities in KB, ascending, without duplicates, including the L3's.
  const std::vector<std::uint64_t>& capacities_kb() const { return capacities_kb_; }
  const std::vector<SliceCounts>& slices() const { return slices_; }
  SliceCounts total() const;
  std::uint64_t instructions() const { return instructions_; }
  // Distinct data lines touched.
  std::uint64_t footprint_lines() const { return touched_.size(); }

 private:
  void touch(std::uint64_t line, bool write, bool load);
  void l3_stream(std::uint64_t line, bool refill);

  ProfilerConfig config_;
  std::vector<std::uint64_t> capacities_kb_, capacities_lines_;
  PrivateHierarchy hierarchy_;
  StackDistance l3_stack_;
  std::unordered_set<std::uint64_t> touched_;
  std::vector<SliceCounts> slices_;
  SliceCounts current_;
  std::uint64_t instructions_ = 0;
  std::deque<std::uint64_t> recent_refills_;  // instruction index of the refills in the window
};

struct Phase {
  SliceCounts counts;  // the sum of its slices
  std::size_t first_slice = 0, slice_count = 0;
};

// Merges adjacent slices into phases: a slice joins the current phase when its L2 refill and
// write-back rates are each within `relative` of the phase's so far (or within `absolute_pki`,
// so that near-zero rates do not split). When that leaves more than `max_phases`, adjacent
// slices are joined in pairs while there are more than 16 x `max_phases` of them (a long run
// that alternates at slice scale keeps its stages apart), and then the tolerances double, until
// it does not.
std::vector<Phase> merge_phases(const std::vector<SliceCounts>& slices, double relative = 0.25,
                                double absolute_pki = 0.5, std::size_t max_phases = 32);

// One line of valgrind lackey's --trace-mem=yes output ("I  0400d7d4,8", " L 0421d000,8",
// " S ...", " M ..."): the parsed event, or nullopt for any other line (valgrind's messages).
struct TraceEvent {
  enum class Kind { Instruction, Load, Store, Modify } kind;
  std::uint64_t address = 0;
  std::uint64_t size = 0;
};
std::optional<TraceEvent> parse_lackey_line(std::string_view line);

}  // namespace rosguard::profile

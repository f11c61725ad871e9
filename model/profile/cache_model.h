// Cache models behind `rosguard profile` (tools/rosguard/host/profile.*): a set-associative LRU
// cache (write-back, write-allocate), the private L1 + L2 of one core built from two of them,
// and Mattson's LRU stack distances for the miss-ratio curve of the L2 miss stream.
//
// Contract: plain single-threaded objects fed one access at a time, in program order. Addresses
// are byte addresses; everything is counted in cache lines (`line_bytes`, 64 by default).
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <unordered_map>
#include <vector>

namespace rosguard::profile {

struct CacheGeometry {
  std::uint64_t size_bytes = 0;
  unsigned ways = 1;
  unsigned line_bytes = 64;

  std::uint64_t lines() const { return size_bytes / line_bytes; }
  std::uint64_t sets() const { return lines() / ways; }
};

// Throws InputError (a command-line input) unless size, ways and line size are positive, the line
// size is a power of two and the size a whole number of sets (size = sets x ways x line).
void check_geometry(const CacheGeometry& g, const std::string& what);

// One set-associative cache with true LRU replacement in each set.
class LruCache {
 public:
  explicit LruCache(const CacheGeometry& geometry);

  struct Result {
    bool hit = false;
    bool evicted = false;        // a valid line was evicted to make room
    bool evicted_dirty = false;  // ... and it was dirty (a write-back)
    std::uint64_t victim = 0;    // the evicted line (line number, not byte address)
  };
  // Looks up `line` (address / line_bytes); on a miss allocates it, evicting the set's LRU
  // line. `write` marks the line dirty.
  Result access(std::uint64_t line, bool write);

  const CacheGeometry& geometry() const { return geometry_; }

 private:
  static constexpr std::uint64_t kInvalid = std::numeric_limits<std::uint64_t>::max();
  CacheGeometry geometry_;
  std::uint64_t sets_;
  // Per set `ways` entries, most recently used first.
  std::vector<std::uint64_t> tags_;
  std::vector<std::uint8_t> dirty_;
};

// What one access did below the L1: the lines the L2 fetched from the next level (refills) and
// the dirty lines it evicted to it (write-backs), in that order of events.
struct L2Traffic {
  bool l1_miss = false;
  bool l1_writeback = false;
  bool l2_refill = false;  // the accessed line came from beyond the L2
  std::uint64_t refill_line = 0;
  unsigned writebacks = 0;  // at most 2: one for the L1 victim's allocation, one for the refill
  std::uint64_t writeback_lines[2] = {0, 0};
};

// A core's private L1 data cache and L2, both write-back and write-allocate, non-inclusive: an
// L1 miss looks up the L2 (a miss there is an L2 refill); a dirty L1 victim is written into the
// L2, allocated there without a refill when absent (the whole line is written); a dirty L2
// victim is an L2 write-back.
class PrivateHierarchy {
 public:
  PrivateHierarchy(const CacheGeometry& l1, const CacheGeometry& l2);

  // One access to one line (a load, or with `write` a store or read-modify-write).
  L2Traffic access(std::uint64_t line, bool write);

  unsigned line_bytes() const { return l1_.geometry().line_bytes; }

 private:
  LruCache l1_, l2_;
};

// Mattson's stack algorithm: the LRU stack distance of each access (the number of distinct
// lines touched since the previous access to the same line), exact, in O(log n) per access with
// a Fenwick tree over access times (re-numbered when it fills). An access hits in a fully
// associative LRU cache of C lines iff its distance is < C; a first access has distance
// kFirstTouch.
class StackDistance {
 public:
  static constexpr std::uint64_t kFirstTouch = std::numeric_limits<std::uint64_t>::max();

  StackDistance();
  std::uint64_t access(std::uint64_t line);
  std::uint64_t distinct_lines() const { return last_.size(); }

 private:
  void add(std::uint64_t pos, int delta);
  std::uint64_t prefix(std::uint64_t pos) const;  // marks at times <= pos
  void renumber();

  std::unordered_map<std::uint64_t, std::uint64_t> last_;  // line -> time of its last access
  std::vector<std::int32_t> tree_;                         // Fenwick tree, 1-based
  std::uint64_t now_ = 0;
};

}  // namespace rosguard::profile

#include "profile/cache_model.h"

#include <algorithm>
#include <utility>

#include "core/error.h"

namespace rosguard::profile {

void check_geometry(const CacheGeometry& g, const std::string& what) {
  const auto fail = [&](const std::string& why) { throw InputError("", "", what + ": " + why); };
  if (g.line_bytes == 0 || (g.line_bytes & (g.line_bytes - 1)) != 0)
    fail("the line size must be a power of two (got " + std::to_string(g.line_bytes) + ")");
  if (g.ways == 0) fail("at least one way");
  if (g.size_bytes == 0 || g.size_bytes % (std::uint64_t{g.ways} * g.line_bytes) != 0)
    fail("the size (" + std::to_string(g.size_bytes) + " bytes) must be a positive multiple of " +
         "ways x line (" + std::to_string(g.ways) + " x " + std::to_string(g.line_bytes) + ")");
}

namespace {
const CacheGeometry& checked(const CacheGeometry& g) {
  check_geometry(g, "cache");
  return g;
}
}  // namespace

// checked() first: sets() divides by the ways.
LruCache::LruCache(const CacheGeometry& geometry)
    : geometry_(checked(geometry)),
      sets_(geometry.sets()),
      tags_(geometry.sets() * geometry.ways, kInvalid),
      dirty_(geometry.sets() * geometry.ways, 0) {}

LruCache::Result LruCache::access(std::uint64_t line, bool write) {
  const unsigned ways = geometry_.ways;
  const std::size_t base = static_cast<std::size_t>(line % sets_) * ways;
  std::uint64_t* tags = tags_.data() + base;
  std::uint8_t* dirty = dirty_.data() + base;
  Result r;
  unsigned way = 0;
  while (way < ways && tags[way] != line)
    ++way;
  std::uint8_t was_dirty = 0;
  if (way < ways) {
    r.hit = true;
    was_dirty = dirty[way];
  } else {
    way = ways - 1;  // the LRU entry makes room
    if (tags[way] != kInvalid) {
      r.evicted = true;
      r.evicted_dirty = dirty[way] != 0;
      r.victim = tags[way];
    }
  }
  // Move to the front (most recently used).
  std::move_backward(tags, tags + way, tags + way + 1);
  std::move_backward(dirty, dirty + way, dirty + way + 1);
  tags[0] = line;
  dirty[0] = static_cast<std::uint8_t>(was_dirty | (write ? 1 : 0));
  return r;
}

PrivateHierarchy::PrivateHierarchy(const CacheGeometry& l1, const CacheGeometry& l2)
    : l1_(l1), l2_(l2) {}

L2Traffic PrivateHierarchy::access(std::uint64_t line, bool write) {
  L2Traffic t;
  const LruCache::Result r1 = l1_.access(line, write);
  if (r1.hit) return t;
  t.l1_miss = true;
  const LruCache::Result r2 = l2_.access(line, false);
  if (!r2.hit) {
    t.l2_refill = true;
    t.refill_line = line;
  }
  if (r2.evicted_dirty) t.writeback_lines[t.writebacks++] = r2.victim;
  if (r1.evicted_dirty) {
    t.l1_writeback = true;
    // Written into the L2 whole: no refill when it is absent, only an allocation.
    const LruCache::Result w = l2_.access(r1.victim, true);
    if (w.evicted_dirty) t.writeback_lines[t.writebacks++] = w.victim;
  }
  return t;
}

StackDistance::StackDistance() : tree_((1u << 16) + 1, 0) {}

void StackDistance::add(std::uint64_t pos, int delta) {
  for (std::uint64_t i = pos + 1; i < tree_.size(); i += i & (~i + 1))
    tree_[i] += delta;
}

std::uint64_t StackDistance::prefix(std::uint64_t pos) const {
  std::int64_t sum = 0;
  for (std::uint64_t i = pos + 1; i > 0; i -= i & (~i + 1))
    sum += tree_[i];
  return static_cast<std::uint64_t>(sum);
}

// Times only order the accesses: when they run out, give the live marks (one per distinct line)
// the times 0 .. n-1 in the same order, in a tree at least twice that size.
void StackDistance::renumber() {
  std::vector<std::pair<std::uint64_t, std::uint64_t>> marks;  // (time, line)
  marks.reserve(last_.size());
  for (const auto& [line, time] : last_)
    marks.emplace_back(time, line);
  std::sort(marks.begin(), marks.end());
  const std::size_t size = std::max<std::size_t>(tree_.size() - 1, 2 * marks.size() + 1);
  tree_.assign(size + 1, 0);
  for (std::uint64_t i = 0; i < marks.size(); ++i) {
    last_[marks[i].second] = i;
    // O(n) build: each node adds itself to its parent.
    tree_[i + 1] += 1;
  }
  for (std::uint64_t i = 1; i < tree_.size(); ++i) {
    const std::uint64_t parent = i + (i & (~i + 1));
    if (parent < tree_.size()) tree_[parent] += tree_[i];
  }
  now_ = marks.size();
}

std::uint64_t StackDistance::access(std::uint64_t line) {
  if (now_ + 1 >= tree_.size()) renumber();
  std::uint64_t distance = kFirstTouch;
  const auto [it, inserted] = last_.try_emplace(line, now_);
  if (!inserted) {
    const std::uint64_t before = it->second;
    distance = last_.size() - prefix(before);  // marks after the previous access
    add(before, -1);
    it->second = now_;
  }
  add(now_, +1);
  ++now_;
  return distance;
}

}  // namespace rosguard::profile

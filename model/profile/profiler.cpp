#include "profile/profiler.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <utility>

#include "core/error.h"

namespace rosguard::profile {

void SliceCounts::add(const SliceCounts& o) {
  instructions += o.instructions;
  loads += o.loads;
  stores += o.stores;
  l1_refills += o.l1_refills;
  l1_writebacks += o.l1_writebacks;
  l2_refills += o.l2_refills;
  l2_writebacks += o.l2_writebacks;
  refill_overlap += o.refill_overlap;
  if (l3_misses.size() < o.l3_misses.size()) l3_misses.resize(o.l3_misses.size(), 0);
  for (std::size_t i = 0; i < o.l3_misses.size(); ++i)
    l3_misses[i] += o.l3_misses[i];
}

double SliceCounts::mlp() const {
  return l2_refills ? static_cast<double>(refill_overlap) / static_cast<double>(l2_refills) : 1.0;
}

Profiler::Profiler(ProfilerConfig config)
    : config_(std::move(config)), hierarchy_(config_.l1, config_.l2) {
  check_geometry(config_.l3, "L3");
  if (config_.l1.line_bytes != config_.l2.line_bytes ||
      config_.l1.line_bytes != config_.l3.line_bytes)
    throw InputError("", "", "the caches must have one line size");
  if (config_.slice_instructions == 0) throw InputError("", "", "a slice needs instructions");
  capacities_kb_ = config_.mrc_capacities_kb;
  capacities_kb_.push_back(config_.l3.size_bytes / 1024);
  std::sort(capacities_kb_.begin(), capacities_kb_.end());
  capacities_kb_.erase(std::unique(capacities_kb_.begin(), capacities_kb_.end()),
                       capacities_kb_.end());
  for (const std::uint64_t kb : capacities_kb_) {
    if (kb == 0) throw InputError("", "", "an MRC capacity must be positive");
    capacities_lines_.push_back(kb * 1024 / config_.l1.line_bytes);
  }
  current_.l3_misses.assign(capacities_kb_.size(), 0);
}

void Profiler::instruction() {
  if (current_.instructions == config_.slice_instructions) {
    slices_.push_back(current_);
    current_ = SliceCounts{};
    current_.l3_misses.assign(capacities_kb_.size(), 0);
  }
  ++current_.instructions;
  ++instructions_;
}

void Profiler::access(std::uint64_t address, std::uint64_t size, AccessKind kind) {
  const unsigned shift = static_cast<unsigned>(std::countr_zero(config_.l1.line_bytes));
  const bool write = kind != AccessKind::Load;
  if (kind != AccessKind::Store) ++current_.loads;
  if (kind != AccessKind::Load) ++current_.stores;
  const std::uint64_t first = address >> shift;
  const std::uint64_t last = (address + std::max<std::uint64_t>(size, 1) - 1) >> shift;
  for (std::uint64_t line = first; line <= last; ++line)
    touch(line, write, kind != AccessKind::Store);
}

void Profiler::touch(std::uint64_t line, bool write, bool /*load*/) {
  const L2Traffic t = hierarchy_.access(line, write);
  if (!t.l1_miss) return;
  ++current_.l1_refills;
  if (t.l1_writeback) ++current_.l1_writebacks;
  touched_.insert(line);  // a first touch always misses the L1
  if (t.l2_refill) {
    ++current_.l2_refills;
    // Refills in flight together: those issued within the reorder window (an upper bound: the
    // trace does not say which loads depend on which).
    while (!recent_refills_.empty() &&
           instructions_ - recent_refills_.front() >= config_.mlp_window_instructions)
      recent_refills_.pop_front();
    recent_refills_.push_back(instructions_);
    current_.refill_overlap += recent_refills_.size();
    l3_stream(t.refill_line, true);
  }
  for (unsigned i = 0; i < t.writebacks; ++i) {
    ++current_.l2_writebacks;
    l3_stream(t.writeback_lines[i], false);
  }
}

void Profiler::l3_stream(std::uint64_t line, bool refill) {
  const std::uint64_t d = l3_stack_.access(line);
  if (!refill) return;  // a write-back places the line in the L3 (it counts in its stack only)
  for (std::size_t i = 0; i < capacities_lines_.size(); ++i)
    if (d >= capacities_lines_[i]) ++current_.l3_misses[i];
}

void Profiler::finish() {
  if (current_.instructions > 0) slices_.push_back(current_);
  current_ = SliceCounts{};
  current_.l3_misses.assign(capacities_kb_.size(), 0);
}

void Profiler::reset_counts() {
  slices_.clear();
  current_ = SliceCounts{};
  current_.l3_misses.assign(capacities_kb_.size(), 0);
  instructions_ = 0;
  touched_.clear();
  recent_refills_.clear();
}

SliceCounts Profiler::total() const {
  SliceCounts sum;
  sum.l3_misses.assign(capacities_kb_.size(), 0);
  for (const SliceCounts& s : slices_)
    sum.add(s);
  return sum;
}

namespace {

bool close(double a, double b, double relative, double absolute) {
  return std::abs(a - b) <= std::max(absolute, relative * std::max(a, b));
}

std::vector<Phase> merge_once(const std::vector<SliceCounts>& slices, double relative,
                              double absolute_pki) {
  std::vector<Phase> phases;
  for (std::size_t i = 0; i < slices.size(); ++i) {
    const SliceCounts& s = slices[i];
    if (!phases.empty()) {
      Phase& p = phases.back();
      if (close(s.pki(s.l2_refills), p.counts.pki(p.counts.l2_refills), relative, absolute_pki) &&
          close(s.pki(s.l2_writebacks), p.counts.pki(p.counts.l2_writebacks), relative,
                absolute_pki)) {
        p.counts.add(s);
        ++p.slice_count;
        continue;
      }
    }
    phases.push_back(Phase{s, i, 1});
  }
  return phases;
}

}  // namespace

std::vector<Phase> merge_phases(const std::vector<SliceCounts>& slices, double relative,
                                double absolute_pki, std::size_t max_phases) {
  const std::size_t most = std::max<std::size_t>(max_phases, 1);
  // A long run (thousands of slices) alternates between rates at slice scale: pairs of slices
  // are joined first, while there are more than 16 per phase allowed, so that its stages stay
  // apart; only then do the tolerances grow.
  std::vector<SliceCounts> coarse = slices;
  std::size_t factor = 1;
  std::vector<Phase> phases = merge_once(coarse, relative, absolute_pki);
  while (phases.size() > most) {
    if (coarse.size() > 16 * most) {
      std::vector<SliceCounts> joined((coarse.size() + 1) / 2);
      for (std::size_t i = 0; i < coarse.size(); ++i)
        if (i % 2 == 0)
          joined[i / 2] = coarse[i];
        else
          joined[i / 2].add(coarse[i]);
      coarse = std::move(joined);
      factor *= 2;
    } else {
      relative *= 2;
      absolute_pki *= 2;
    }
    phases = merge_once(coarse, relative, absolute_pki);
  }
  for (Phase& p : phases) {
    p.first_slice *= factor;
    p.slice_count = std::min(p.slice_count * factor, slices.size() - p.first_slice);
  }
  return phases;
}

namespace {

bool parse_hex(std::string_view s, std::uint64_t& value) {
  if (s.empty() || s.size() > 16) return false;
  value = 0;
  for (const char c : s) {
    unsigned d;
    if (c >= '0' && c <= '9')
      d = static_cast<unsigned>(c - '0');
    else if (c >= 'a' && c <= 'f')
      d = static_cast<unsigned>(c - 'a' + 10);
    else if (c >= 'A' && c <= 'F')
      d = static_cast<unsigned>(c - 'A' + 10);
    else
      return false;
    value = (value << 4) | d;
  }
  return true;
}

bool parse_dec(std::string_view s, std::uint64_t& value) {
  if (s.empty() || s.size() > 9) return false;
  value = 0;
  for (const char c : s) {
    if (c < '0' || c > '9') return false;
    value = value * 10 + static_cast<unsigned>(c - '0');
  }
  return true;
}

}  // namespace

std::optional<TraceEvent> parse_lackey_line(std::string_view line) {
  if (line.size() < 3) return std::nullopt;
  TraceEvent e{};
  if (line[0] == 'I' && line[1] == ' ')
    e.kind = TraceEvent::Kind::Instruction;
  else if (line[0] == ' ' && line[2] == ' ' && (line[1] == 'L' || line[1] == 'S' || line[1] == 'M'))
    e.kind = line[1] == 'L'   ? TraceEvent::Kind::Load
             : line[1] == 'S' ? TraceEvent::Kind::Store
                              : TraceEvent::Kind::Modify;
  else
    return std::nullopt;
  std::string_view rest = line.substr(2);
  while (!rest.empty() && rest.front() == ' ')
    rest.remove_prefix(1);
  const auto comma = rest.find(',');
  if (comma == std::string_view::npos) return std::nullopt;
  if (!parse_hex(rest.substr(0, comma), e.address) || !parse_dec(rest.substr(comma + 1), e.size))
    return std::nullopt;
  return e;
}

}  // namespace rosguard::profile

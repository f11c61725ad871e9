#include "profile/callgrind.h"

#include <cmath>
#include <cstdlib>
#include <sstream>

namespace rosguard::profile {

std::uint64_t CallgrindDump::at(const std::string& event) const {
  const auto it = counts.find(event);
  return it == counts.end() ? 0 : it->second;
}

std::optional<CallgrindDump> parse_callgrind_dump(std::string_view text) {
  CallgrindDump d;
  std::vector<std::string> events;
  std::vector<std::uint64_t> summary;
  std::size_t begin = 0;
  while (begin < text.size()) {
    std::size_t end = text.find('\n', begin);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = text.substr(begin, end - begin);
    begin = end + 1;
    const auto words = [](std::string_view rest) {
      std::vector<std::string> out;
      std::istringstream in{std::string(rest)};
      for (std::string w; in >> w;)
        out.push_back(w);
      return out;
    };
    if (line.rfind("part:", 0) == 0) {
      d.part = std::atoi(std::string(line.substr(5)).c_str());
    } else if (line.rfind("events:", 0) == 0) {
      events = words(line.substr(7));
    } else if (summary.empty() &&
               (line.rfind("summary:", 0) == 0 || line.rfind("totals:", 0) == 0)) {
      for (const std::string& w : words(line.substr(line.find(':') + 1)))
        summary.push_back(std::strtoull(w.c_str(), nullptr, 10));
    }
  }
  if (events.empty() || summary.empty()) return std::nullopt;
  // Trailing zero counts may be left out of a cost line.
  for (std::size_t i = 0; i < events.size(); ++i)
    d.counts[events[i]] = i < summary.size() ? summary[i] : 0;
  return d;
}

namespace {

std::uint64_t data_misses(const CallgrindDump& d) {
  return d.at("DLmr") + d.at("DLmw");
}

bool aligned(const std::vector<CallgrindDump>& a, const std::vector<CallgrindDump>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t k = 0; k < a.size(); ++k) {
    const double x = static_cast<double>(a[k].at("Ir")), y = static_cast<double>(b[k].at("Ir"));
    if (std::abs(x - y) > 0.01 * std::max(x, y)) return false;
  }
  return true;
}

}  // namespace

CallgrindSlices callgrind_slices(const std::vector<CallgrindDump>& l2_run,
                                 const std::vector<std::vector<CallgrindDump>>& capacity_runs) {
  CallgrindSlices out;
  std::uint64_t l2_total = 0;
  for (const CallgrindDump& d : l2_run) {
    SliceCounts s;
    s.instructions = d.at("Ir");
    s.loads = d.at("Dr");
    s.stores = d.at("Dw");
    s.l1_refills = d.at("D1mr") + d.at("D1mw");
    s.l2_refills = data_misses(d);
    s.l2_writebacks = d.at("DLdmr") + d.at("DLdmw");
    s.l3_misses.assign(capacity_runs.size(), 0);
    l2_total += s.l2_refills;
    out.slices.push_back(std::move(s));
  }
  for (std::size_t i = 0; i < capacity_runs.size(); ++i) {
    const auto& run = capacity_runs[i];
    if (aligned(l2_run, run)) {
      for (std::size_t k = 0; k < run.size(); ++k)
        out.slices[k].l3_misses[i] = std::min(data_misses(run[k]), out.slices[k].l2_refills);
      continue;
    }
    std::uint64_t total = 0;
    for (const CallgrindDump& d : run)
      total += data_misses(d);
    const double ratio =
        l2_total ? std::min(1.0, static_cast<double>(total) / static_cast<double>(l2_total)) : 0.0;
    for (SliceCounts& s : out.slices)
      s.l3_misses[i] =
          static_cast<std::uint64_t>(std::llround(ratio * static_cast<double>(s.l2_refills)));
    out.misaligned.push_back(i);
  }
  return out;
}

unsigned callgrind_ways(std::uint64_t size_bytes, unsigned ways, unsigned line_bytes) {
  const auto fits = [&](unsigned w) {
    if (w == 0 || size_bytes % (static_cast<std::uint64_t>(w) * line_bytes) != 0) return false;
    const std::uint64_t sets = size_bytes / (static_cast<std::uint64_t>(w) * line_bytes);
    return sets > 0 && (sets & (sets - 1)) == 0;
  };
  if (fits(ways)) return ways;
  for (unsigned d = 1; d < 64; ++d) {
    if (ways > d && fits(ways - d)) return ways - d;
    if (ways + d <= 64 && fits(ways + d)) return ways + d;
  }
  return 0;
}

}  // namespace rosguard::profile

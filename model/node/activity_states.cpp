#include "node/activity_states.h"

namespace rosguard {

ActivityStates::ActivityStates(std::size_t rt_count, TimeNs max_active_ns)
    : holders_(rt_count), max_active_ns_(max_active_ns) {}

ActivityStates::Verdict ActivityStates::set(std::size_t rt, const std::string& publisher,
                                            bool active, TimeNs t) {
  auto& h = holders_.at(rt);
  const auto it = h.find(publisher);
  if (active) {
    if (it != h.end()) return Verdict::Duplicate;
    h.emplace(publisher, t);
    return h.size() == 1 ? Verdict::Started : Verdict::Joined;
  }
  if (it == h.end()) return Verdict::Unmatched;
  h.erase(it);
  return h.empty() ? Verdict::Ended : Verdict::Left;
}

std::vector<ActivityStates::Release> ActivityStates::gone(const std::string& publisher) {
  std::vector<Release> out;
  for (std::size_t rt = 0; rt < holders_.size(); ++rt) {
    auto& h = holders_[rt];
    if (const auto it = h.find(publisher); it != h.end()) {
      out.push_back({rt, publisher, it->second, h.size() == 1});
      h.erase(it);
    }
  }
  return out;
}

std::vector<ActivityStates::Release> ActivityStates::expire(TimeNs now) {
  std::vector<Release> out;
  if (max_active_ns_ <= 0) return out;
  for (std::size_t rt = 0; rt < holders_.size(); ++rt) {
    auto& h = holders_[rt];
    for (auto it = h.begin(); it != h.end();) {
      if (now - it->second > max_active_ns_) {
        out.push_back({rt, it->first, it->second, h.size() == 1});
        it = h.erase(it);
      } else {
        ++it;
      }
    }
  }
  return out;
}

TimeNs ActivityStates::held_since(std::size_t rt, const std::string& publisher) const {
  const auto& h = holders_.at(rt);
  const auto it = h.find(publisher);
  return it == h.end() ? -1 : it->second;
}

const char* to_string(ActivityStates::Verdict v) {
  switch (v) {
    case ActivityStates::Verdict::Started:
      return "started";
    case ActivityStates::Verdict::Joined:
      return "joined";
    case ActivityStates::Verdict::Ended:
      return "ended";
    case ActivityStates::Verdict::Left:
      return "left";
    case ActivityStates::Verdict::Duplicate:
      return "duplicate";
    case ActivityStates::Verdict::Unmatched:
      return "unmatched";
  }
  return "?";
}

}  // namespace rosguard

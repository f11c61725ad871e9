// The RT nodes' activity as state owned by its publishers (rosguard guard, hw/guard/guard.h).
// Each RT node is active while at least one publisher holds it:
// - a publisher's `true` makes it a holder, its `false` releases it;
// - a publisher that disappears (its writer gone) releases whatever it held;
// - a holder that has held a node longer than the maximum activation is released (a warning).
// A second `true` from a holder, or a `false` from a publisher that holds nothing, changes nothing
// (the caller logs it). Only the node's own transitions (the first holder in, the last one out)
// go on to the regulator, so the starts and ends it sees always pair up, whatever arrives.
//
// Contract: pure (no clock, no OS calls: callers pass the time); not thread-safe (the guard calls
// it under its own lock).
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "core/types.h"

namespace rosguard {

class ActivityStates {
 public:
  // max_active_ns <= 0: no maximum.
  ActivityStates(std::size_t rt_count, TimeNs max_active_ns);

  enum class Verdict {
    Started,    // the node became active (first holder)
    Joined,     // another publisher holds the already active node too
    Ended,      // the node became inactive (its last holder released it)
    Left,       // a holder released the node; others still hold it
    Duplicate,  // `true` from a publisher that holds it already: ignored
    Unmatched,  // `false` from a publisher that holds nothing: ignored
  };
  struct Release {
    std::size_t rt = 0;
    std::string publisher;
    TimeNs since = 0;         // when that publisher's `true` came
    bool node_ended = false;  // it was the node's last holder
  };

  Verdict set(std::size_t rt, const std::string& publisher, bool active, TimeNs t);
  // The publisher is gone: it releases every node it held.
  std::vector<Release> gone(const std::string& publisher);
  // Holders beyond the maximum activation at `now` are released.
  std::vector<Release> expire(TimeNs now);

  bool active(std::size_t rt) const { return !holders_.at(rt).empty(); }
  std::size_t holders(std::size_t rt) const { return holders_.at(rt).size(); }
  // When `publisher` took hold of `rt` (-1 when it holds nothing there).
  TimeNs held_since(std::size_t rt, const std::string& publisher) const;

 private:
  std::vector<std::map<std::string, TimeNs>> holders_;  // per RT node: publisher -> since
  TimeNs max_active_ns_;
};

const char* to_string(ActivityStates::Verdict v);

}  // namespace rosguard

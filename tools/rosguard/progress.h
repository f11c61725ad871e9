// Progress of `rosguard run` on a terminal: one line on stderr, rewritten in place ("[done/total]
// percent, elapsed, ETA, what finished last"). Silent when disabled or stderr is not a tty.
#pragma once

#include <chrono>
#include <cstddef>
#include <string>

namespace rosguard {

class Progress {
 public:
  Progress(std::size_t total, bool enabled);
  void update(std::size_t done, const std::string& what);
  // Clears the line (before other output, and at the end).
  void finish();
  // Seconds since construction.
  double seconds() const;

 private:
  using clock = std::chrono::steady_clock;
  std::size_t total_;
  bool enabled_;
  clock::time_point start_;
};

}  // namespace rosguard

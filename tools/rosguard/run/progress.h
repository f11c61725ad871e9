// Progress of `rosguard run` on stderr: "[done/total] percent, elapsed, ETA, what finished last",
// counting point runs (baselines measured between them are not counted, but named).
// On a terminal: one line rewritten in place at most every `interval` seconds (0.1 s: a sweep
// finishes hundreds of runs a second, and the terminal's redraws would take CPU from them),
// clipped to the terminal's width so that it never wraps (a wrapped line leaves a stale row
// behind at every update). Elsewhere (a pipe, a log file, CI, a Slurm job's output): a plain
// line every `interval` seconds (5 s) and one at the end.
#pragma once

#include <chrono>
#include <cstddef>
#include <functional>
#include <ostream>
#include <string>
#include <utility>

namespace rosguard {

class Progress {
 public:
  enum class Mode { Off, Terminal, Lines };

  // Mode from `enabled` and whether stderr is a terminal.
  Progress(std::size_t total, bool enabled);
  // Explicit mode and stream (tests): `columns` is the terminal width for Terminal; at most one
  // line or redraw per `interval_s`.
  Progress(std::size_t total, Mode mode, std::ostream& out, std::size_t columns = 80,
           double interval_s = 5.0);

  void update(std::size_t done, const std::string& what);
  // The same, with `what` made only when a line is printed (a label per run costs the runner of
  // a large sweep more than the line does).
  void update(std::size_t done, const std::function<std::string()>& what);
  // A new total, for work whose size is re-estimated as it goes (adaptive repetitions add rounds;
  // the calibration suite's windows shrink as measurements finish early); the ETA follows it.
  void set_total(std::size_t total) { total_ = total; }
  std::size_t total() const { return total_; }
  // What is counted, shown after the total ("runs" unless set).
  void set_unit(std::string unit) { unit_ = std::move(unit); }
  // Clears the in-place line (before other output, and at the end); in Lines mode prints the
  // final count once if it was not the last line printed.
  void finish();
  // Seconds since construction.
  double seconds() const;

 private:
  using clock = std::chrono::steady_clock;
  std::string text(std::size_t done, const std::string& what) const;

  std::size_t total_;
  Mode mode_;
  std::ostream& out_;
  std::size_t columns_;
  double interval_s_;
  clock::time_point start_;
  double last_line_s_ = -1e300;
  std::size_t done_ = 0, printed_ = static_cast<std::size_t>(-1);
  std::string unit_ = "runs";
};

}  // namespace rosguard

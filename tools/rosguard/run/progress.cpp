#include "run/progress.h"

#include <sys/ioctl.h>
#include <unistd.h>

#include <cstdio>
#include <iostream>

namespace rosguard {
namespace {

Progress::Mode mode_of(bool enabled) {
  if (!enabled) return Progress::Mode::Off;
  return ::isatty(STDERR_FILENO) ? Progress::Mode::Terminal : Progress::Mode::Lines;
}

// The terminal's width; 80 where it cannot be read.
std::size_t terminal_columns() {
  winsize ws{};
  if (::ioctl(STDERR_FILENO, TIOCGWINSZ, &ws) == 0 && ws.ws_col > 0) return ws.ws_col;
  return 80;
}

std::string duration_text(double s) {
  char buf[32];
  if (s < 60)
    std::snprintf(buf, sizeof buf, "%.1fs", s);
  else if (s < 3600)
    std::snprintf(buf, sizeof buf, "%dm%02ds", static_cast<int>(s) / 60, static_cast<int>(s) % 60);
  else
    std::snprintf(buf, sizeof buf, "%dh%02dm", static_cast<int>(s) / 3600,
                  static_cast<int>(s) % 3600 / 60);
  return buf;
}

}  // namespace

Progress::Progress(std::size_t total, bool enabled)
    : Progress(total, mode_of(enabled), std::cerr,
               mode_of(enabled) == Mode::Terminal ? terminal_columns() : 80,
               mode_of(enabled) == Mode::Terminal ? 0.1 : 5.0) {}

Progress::Progress(std::size_t total, Mode mode, std::ostream& out, std::size_t columns,
                   double interval_s)
    : total_(total),
      mode_(mode),
      out_(out),
      columns_(columns),
      interval_s_(interval_s),
      start_(clock::now()) {}

std::string Progress::text(std::size_t done, const std::string& what) const {
  const double elapsed = seconds();
  const double pct =
      total_ ? 100.0 * static_cast<double>(done) / static_cast<double>(total_) : 100.0;
  std::string line = "[" + std::to_string(done) + "/" + std::to_string(total_) + " " + unit_ + "] ";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.0f%%", pct);
  line += buf;
  line += "  " + duration_text(elapsed) + " elapsed";
  if (done > 0 && done < total_)
    line += ", ETA " +
            duration_text(elapsed * static_cast<double>(total_ - done) / static_cast<double>(done));
  if (!what.empty()) line += "  " + what;
  return line;
}

void Progress::update(std::size_t done, const std::string& what) {
  update(done, [&what] { return what; });
}

void Progress::update(std::size_t done, const std::function<std::string()>& what) {
  done_ = done;
  if (mode_ == Mode::Off) return;
  const double now = seconds();
  if (now - last_line_s_ < interval_s_) return;
  last_line_s_ = now;
  if (mode_ == Mode::Terminal) {
    std::string line = text(done, what());
    // One column spare: writing the last column makes some terminals wrap at once.
    if (columns_ > 1 && line.size() > columns_ - 1) line.resize(columns_ - 1);
    out_ << "\r\033[K" << line << std::flush;
  } else {
    printed_ = done;
    out_ << "progress: " << text(done, what()) << "\n" << std::flush;
  }
}

void Progress::finish() {
  if (mode_ == Mode::Terminal) {
    out_ << "\r\033[K" << std::flush;
  } else if (mode_ == Mode::Lines && printed_ != done_ && done_ == total_ && total_ > 0) {
    printed_ = done_;
    out_ << "progress: " << text(done_, "") << "\n" << std::flush;
  }
}

double Progress::seconds() const {
  return std::chrono::duration<double>(clock::now() - start_).count();
}

}  // namespace rosguard

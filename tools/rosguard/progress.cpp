#include "progress.h"

#include <unistd.h>

#include <cstdio>
#include <iostream>

namespace rosguard {

Progress::Progress(std::size_t total, bool enabled)
    : total_(total), enabled_(enabled && ::isatty(STDERR_FILENO)), start_(clock::now()) {}

void Progress::update(std::size_t done, const std::string& what) {
  if (!enabled_) return;
  const double elapsed = seconds();
  char line[256];
  const double eta =
      done ? elapsed * static_cast<double>(total_ - done) / static_cast<double>(done) : 0;
  std::snprintf(line, sizeof line, "\r\033[K[%zu/%zu] %3.0f%%  %.1fs elapsed, ETA %.1fs  %s", done,
                total_,
                total_ ? 100.0 * static_cast<double>(done) / static_cast<double>(total_) : 100.0,
                elapsed, eta, what.substr(0, 80).c_str());
  std::cerr << line << std::flush;
}

void Progress::finish() {
  if (enabled_) std::cerr << "\r\033[K" << std::flush;
}

double Progress::seconds() const {
  return std::chrono::duration<double>(clock::now() - start_).count();
}

}  // namespace rosguard

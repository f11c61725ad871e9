// Shared by the package's tests: cores, a namespace per test, waiting, medians.
#pragma once

#include <rosguard/hw/common/clock.h>
#include <rosguard/hw/common/sys.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <functional>
#include <string>
#include <thread>
#include <vector>

namespace rosguard_rclcpp::test {

// A topic namespace of this process and test alone.
inline std::string unique_ns(const std::string& test) {
  return "/rgtest_" + std::to_string(::getpid()) + "_" + test;
}

// The RT / controller core and the nRT core: the first and the last this process may use.
struct Cores {
  int control = -1, nrt = -1;
  bool two() const { return control >= 0 && nrt >= 0 && control != nrt; }
};
inline Cores test_cores() {
  const auto cpus = rosguard::hw::usable_cpus();
  if (cpus.size() < 2) return {};
  return {cpus.front(), cpus.back()};
}

// Waits until `done` holds, polling every ms, at most `limit`.
inline bool wait_for(const std::function<bool()>& done, std::chrono::milliseconds limit) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < end) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return done();
}

inline double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
}

}  // namespace rosguard_rclcpp::test

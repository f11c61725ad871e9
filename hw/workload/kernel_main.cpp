// rosguard-hw-kernel: one built-in kernel of the hw backend (hw/workload/kernels.cpp) as a
// program of its own, in the calling thread: for `rosguard profile` (which traces a program) and
// to time the kernel alone.
//
//   rosguard-hw-kernel KERNEL WORKING_SET_KB PASSES [RUNS]
//
// Builds the kernel exactly as the hw backend does (make_builtin_workload with {"kernel",
// "working_set_kb", "passes"}: the buffer is mapped and pre-faulted first), runs it RUNS times
// (default 1) and prints each run's lines, seconds, ns per line and MB/s (lines x 64 B / time) on
// stdout. Exit 2 on bad arguments (InputError), 1 on a failure.
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "core/error.h"
#include "hw/workload/work_counters.h"
#include "hw/workload/workload.h"

namespace {

std::uint64_t positive(const char* text, const char* what) {
  char* end = nullptr;
  const unsigned long long v = std::strtoull(text, &end, 10);
  if (!end || *end != '\0' || text[0] == '-' || v == 0)
    throw rosguard::InputError(
        "", "", std::string(what) + " must be a positive integer (got '" + text + "')");
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace rosguard;
  if (argc < 4 || argc > 5) {
    std::fprintf(stderr,
                 "usage: rosguard-hw-kernel KERNEL WORKING_SET_KB PASSES [RUNS]\n"
                 "  KERNEL: bandwidth_read, bandwidth_write or latency\n");
    return 2;
  }
  try {
    const std::string kernel = argv[1];
    const std::uint64_t kb = positive(argv[2], "WORKING_SET_KB");
    const std::uint64_t passes = positive(argv[3], "PASSES");
    const std::uint64_t runs = argc > 4 ? positive(argv[4], "RUNS") : 1;
    WorkloadInfo w;
    w.name = kernel;
    w.origin = "rosguard-hw-kernel";
    w.doc = {{"hw", {{"kernel", kernel}, {"working_set_kb", kb}, {"passes", passes}}}};
    const auto work = hw::make_builtin_workload(w);
    const std::atomic<bool> stop{false};
    hw::WorkCounters counters;
    for (std::uint64_t r = 0; r < runs; ++r) {
      const std::uint64_t before = counters.units_done.load();
      const auto t0 = std::chrono::steady_clock::now();
      work->run(stop, counters);
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const auto lines = static_cast<double>(counters.units_done.load() - before);
      std::printf(
          "%s %llu KB x %llu passes, run %llu: %.0f lines in %.6f s: %.4f ns/line, %.1f MB/s\n",
          kernel.c_str(), static_cast<unsigned long long>(kb),
          static_cast<unsigned long long>(passes), static_cast<unsigned long long>(r + 1), lines, s,
          1e9 * s / lines, lines * 64.0 / s / 1e6);
    }
  } catch (const InputError& e) {
    std::fprintf(stderr, "rosguard-hw-kernel: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rosguard-hw-kernel: %s\n", e.what());
    return 1;
  }
  return 0;
}

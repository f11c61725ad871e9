// rosguard-test-intruder: a process on the DDS domain with no business on rosguard's topics, for
// the tests of issue 23 (the guard and hw runs must ignore it). Publishes, in the order given:
//   active NAME 0|1        one std_msgs/msg/Bool on <ns>/rosguard/NAME/active
//   flood NAME N           N Bools alternating true / false, as fast as it can
//   command NODE CODE N    N rosguard_msgs/msg/Command with this code (THR = 2; 7 is no code)
//   pmc NODE N             N rosguard_msgs/msg/PmcSample with huge counters
//   sleep MS               wait (the writers stay: the publisher is still there)
// Each writer first waits up to --wait-ms for a reader to match (volatile topics keep nothing).
// Prints one line per action: what it wrote and whether a reader was matched.
// Usage: rosguard-test-intruder --ns NS [--wait-ms MS] ACTION...
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "hw/topic/dds/dds.h"

namespace d = rosguard::dds;

namespace {

template <class W>
bool wait_matched(const W& w, int wait_ms) {
  for (int i = 0; i < wait_ms / 10 && w.matched() == 0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  return w.matched() > 0;
}

[[noreturn]] void usage() {
  std::fprintf(stderr,
               "usage: rosguard-test-intruder --ns NS [--wait-ms MS] ACTION...\n"
               "  active NAME 0|1 | flood NAME N | command NODE CODE N | pmc NODE N | sleep MS\n");
  std::exit(2);
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> a(argv + 1, argv + argc);
  std::string ns;
  int wait_ms = 5000;
  std::size_t i = 0;
  for (; i < a.size() && a[i].rfind("--", 0) == 0; i += 2) {
    if (i + 1 >= a.size()) usage();
    if (a[i] == "--ns")
      ns = a[i + 1];
    else if (a[i] == "--wait-ms")
      wait_ms = std::atoi(a[i + 1].c_str());
    else
      usage();
  }
  d::Participant p;
  std::map<std::string, std::unique_ptr<d::Writer<d::BoolMsg>>> actives;
  std::map<std::string, std::unique_ptr<d::Writer<d::CommandMsg>>> commands;
  std::map<std::string, std::unique_ptr<d::Writer<d::PmcSampleMsg>>> pmcs;
  const auto active = [&](const std::string& name) -> d::Writer<d::BoolMsg>& {
    auto& w = actives[name];
    if (!w) w = std::make_unique<d::Writer<d::BoolMsg>>(p, d::active_topic(ns, name));
    return *w;
  };
  try {
    while (i < a.size()) {
      const std::string& op = a[i];
      const auto arg = [&](std::size_t k) -> const std::string& {
        if (i + k >= a.size()) usage();
        return a[i + k];
      };
      if (op == "active") {
        auto& w = active(arg(1));
        const bool m = wait_matched(w, wait_ms);
        w.write(d::BoolMsg{arg(2) == "1"});
        std::printf("active %s %s (matched %d)\n", arg(1).c_str(), arg(2).c_str(), m);
        i += 3;
      } else if (op == "flood") {
        auto& w = active(arg(1));
        const bool m = wait_matched(w, wait_ms);
        const long n = std::atol(arg(2).c_str());
        const auto t0 = std::chrono::steady_clock::now();
        for (long k = 0; k < n; ++k)
          w.write(d::BoolMsg{k % 2 == 0});
        const double ms =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                .count();
        std::printf("flood %s %ld in %.0f ms (matched %d)\n", arg(1).c_str(), n, ms, m);
        i += 3;
      } else if (op == "command") {
        auto& w = commands[arg(1)];
        if (!w) w = std::make_unique<d::Writer<d::CommandMsg>>(p, d::command_topic(ns, arg(1)));
        const bool m = wait_matched(*w, wait_ms);
        const long n = std::atol(arg(3).c_str());
        const auto code = static_cast<std::uint8_t>(std::atoi(arg(2).c_str()));
        for (long k = 0; k < n; ++k)
          w->write(d::CommandMsg{code, 0});
        std::printf("command %s code %d x %ld (matched %d)\n", arg(1).c_str(), code, n, m);
        i += 4;
      } else if (op == "pmc") {
        auto& w = pmcs[arg(1)];
        if (!w) w = std::make_unique<d::Writer<d::PmcSampleMsg>>(p, d::pmc_topic(ns, arg(1)));
        const bool m = wait_matched(*w, wait_ms);
        const long n = std::atol(arg(2).c_str());
        d::PmcSampleMsg s{};
        s.count = 2;
        for (long k = 0; k < n; ++k) {
          s.value[0] = s.value[1] = static_cast<std::uint64_t>(k + 1) << 40;
          w->write(s);
        }
        std::printf("pmc %s x %ld (matched %d)\n", arg(1).c_str(), n, m);
        i += 3;
      } else if (op == "sleep") {
        std::this_thread::sleep_for(std::chrono::milliseconds(std::atoi(arg(1).c_str())));
        i += 2;
      } else {
        usage();
      }
      std::fflush(stdout);
    }
  } catch (const d::DdsError& e) {
    std::fprintf(stderr, "rosguard-test-intruder: %s\n", e.what());
    return 1;
  }
  return 0;
}

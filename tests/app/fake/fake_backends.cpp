// A deterministic fake backend for testing the runner through the real CLI (main.cpp): results
// are a pure function of the point's parameters and the task seed, so runs can be compared byte
// for byte, and the knobs below make tasks slow or failing on purpose.
//   ROSGUARD_FAKE_SLEEP_MS   sleep this long in every task (kill / SIGINT tests)
//   ROSGUARD_FAKE_FAIL_AT    threshold_pct at which run_point throws RunError
//   ROSGUARD_FAKE_ISO_SPREAD a baseline's successive measurements scaled by 1 - s, 1, 1 + s, ...
//                            (a noisy host, for the baseline spread and its warning)
//   ROSGUARD_FAKE_CALLS      append one line per run_point call to this file: the policy
//                            (what a test counts to see which runs an invocation made)
//   ROSGUARD_FAKE_ORDER      append one line per isolation or run_point call to this file:
//                            "iso CORE" or "point THRESHOLD" (the order the runner ran them in)
// Registered as "sim" (a worker process per task, like SystemC) and "hw" (in-process, polling
// stop_requested() like the real hw backend).
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <map>
#include <random>
#include <thread>

#include "backends.h"
#include "core/error.h"

namespace rosguard {
namespace {

class FakeBackend : public Backend {
 public:
  FakeBackend(std::string name, bool per_process)
      : name_(std::move(name)), per_process_(per_process) {}
  std::string_view name() const override { return name_; }
  bool process_per_task() const override { return per_process_; }
  // As the real ones: the "sim" fake measures a baseline once, the "hw" fake repeatedly.
  int baseline_repetitions(const Scenario& s) const override {
    return per_process_ ? 1 : s.hw.baseline_repetitions;
  }
  // The "hw" fake's repetitions are noisy measurements (1 % uniform noise from the task seed):
  // their precision is reported and hw.precision_pct applies, as on the real hw backend.
  bool judges_precision() const override { return !per_process_; }
  void validate(const Scenario&) const override {}

  IsolationResult isolation(const Scenario&, const WorkloadInfo& w, int core, std::uint64_t,
                            RunContext& ctx) override {
    nap(ctx);
    if (const char* order = std::getenv("ROSGUARD_FAKE_ORDER"))
      std::ofstream(order, std::ios::app) << "iso " << core << "\n";
    double base = 1000.0 + 100.0 * static_cast<double>(w.name.size()) + core;
    if (const char* spread = std::getenv("ROSGUARD_FAKE_ISO_SPREAD"))
      base *= 1.0 + std::atof(spread) * static_cast<double>(iso_calls_[{w.name, core}]++ % 3 - 1);
    return {base, 1.5, 1000.0 * static_cast<double>(w.name.size())};
  }

  PointOutcome run_point(const Scenario& s, const Baselines& b, int rep, std::uint64_t seed,
                         RunContext& ctx) override {
    nap(ctx);
    if (const char* calls = std::getenv("ROSGUARD_FAKE_CALLS"))
      std::ofstream(calls, std::ios::app) << s.regulation.policy << "\n";
    if (const char* order = std::getenv("ROSGUARD_FAKE_ORDER"))
      std::ofstream(order, std::ios::app) << "point " << s.regulation.threshold_pct << "\n";
    if (const char* fail = std::getenv("ROSGUARD_FAKE_FAIL_AT");
        fail && std::atof(fail) == s.regulation.threshold_pct)
      throw RunError("fake failure at threshold " + std::string(fail));
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> noise(0.0, 0.01);
    PointOutcome o;
    const double th = s.regulation.threshold_pct;
    for (const auto& n : s.nodes.rt) {
      RtOutcome rt;
      rt.name = n.name;
      rt.time_us = b.at(s, n.workload, n.core).time_us * (1.0 + th / 200 + noise(rng));
      rt.jobs = 1;
      o.rt.push_back(rt);
    }
    for (const auto& n : s.nodes.nrt)
      o.nrt.push_back({n.name, b.at(s, n.workload, n.core).time_us * (1.0 + 30.0 / th), th * 100.0,
                       static_cast<std::uint64_t>(100 / th), 10.0 * rep, 1.0});
    for (int i = 0; i < 5; ++i) {
      o.samples.push_back({"activation_delay", 50.0 + noise(rng) * 1000});
      o.samples.push_back({"pmc_callback", 15.0 + noise(rng) * 100});
    }
    if (TraceSink* t = ctx.trace()) {
      t->span(0, 1000, 1, "rt0", "job");
      t->counter(500, 2, "MB/s", th * 100.0);
      t->instant(700, 2, "nrt0", "THR");
    }
    (void)rep;
    return o;
  }

 private:
  static void nap(RunContext& ctx) {
    const char* ms = std::getenv("ROSGUARD_FAKE_SLEEP_MS");
    if (!ms) return;
    const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(std::atoi(ms));
    while (std::chrono::steady_clock::now() < until) {
      if (ctx.stop_requested()) throw Interrupted();
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }

  std::string name_;
  bool per_process_;
  std::map<std::pair<std::string, int>, int> iso_calls_;  // per (workload, core)
};

}  // namespace

void register_backends(BackendRegistry& registry, const PolicyRegistry&) {
  registry.add({"sim", "fake: a worker process per task",
                [] { return std::make_unique<FakeBackend>("sim", true); }});
  registry.add({"hw", "fake: in-process, one task at a time",
                [] { return std::make_unique<FakeBackend>("hw", false); }});
}

}  // namespace rosguard

// Speed of the sim backend (Google Benchmark; never asserted in tests: the machine is shared).
//
// SystemC elaborates once per process, so each iteration forks a child that elaborates and runs
// one simulation and reports its own wall time; the benchmark uses that as the iteration time
// (UseManualTime). Counters:
//   sim_per_wall    simulated time / wall time of the child's simulate() (elaboration included)
//   ns_per_act      wall time per SystemC process activation of the model
//   activations     process activations per run
//   fork_ms         wall time of the whole child as the parent sees it (fork, run, exit)
// BM_BareScMethod is the reference: SC_METHODs that do nothing but re-trigger themselves.
#include <benchmark/benchmark.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <systemc>
#include <vector>

#include "platform/contention.h"
#include "platform/sim_platform.h"
#include "policy/builtin_registry.h"
#include "system.h"
#include "workload/profile.h"

#ifndef ROSGUARD_BENCH_SOURCE_DIR
#error "ROSGUARD_BENCH_SOURCE_DIR must point at the source tree"
#endif

namespace {

using namespace rosguard;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

json read_json(const std::string& rel) {
  std::ifstream in(std::string(ROSGUARD_BENCH_SOURCE_DIR) + "/" + rel);
  return json::parse(in);
}

sim::SimPlatform orin() {
  return sim::parse_sim_platform(
      build_platform(read_json("scenarios/platforms/orin-agx.json"), "orin-agx.json"));
}

sim::WorkloadProfile profile(const std::string& name) {
  const std::string f = "scenarios/workloads/" + name + ".json";
  return sim::parse_profile({name, f, read_json(f)}, orin(), f, "/sim");
}

// The minimal ROSGuard setup: controller on core 0, bandwidth_read RT on core 1 and nRT on
// core 2, interval policy at 20 %, self-sampling every `sampling_us`, 5 ms regulation periods.
sim::RunConfig minimal_setup(TimeNs sampling_us, int rt_iterations) {
  sim::RunConfig cfg;
  cfg.platform = orin();
  cfg.seed = 1;
  cfg.rt.push_back({"rt0", 1, profile("bandwidth_read"), rt_iterations, std::nullopt});
  cfg.nrt.push_back({"nrt0", 2, profile("bandwidth_read"), true});
  RegulationSpec r;
  r.policy = "interval";
  r.threshold_pct = 20.0;
  r.reference_mbps = 26271.74;
  r.regulation_period_us = 5000;
  r.sampling = Sampling::Self;
  r.sampling_period_us = sampling_us;
  cfg.regulation = regulation_setup(r, {1, 1}, builtin_registry(), "bench_sim");
  return cfg;
}

struct ChildResult {
  double wall_s = 0.0;
  double sim_s = 0.0;
  double activations = 0.0;
  double solves = 0.0;
  double parent_s = 0.0;
};

// Runs `fn` (which returns {simulated seconds, activations, memory solves}) in a forked child,
// timed inside.
template <class F>
ChildResult in_child(F fn) {
  int fds[2];
  if (::pipe(fds) != 0) std::abort();
  const auto t0 = Clock::now();
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(fds[0]);
    const auto start = Clock::now();
    const std::array<double, 3> r = fn();
    const double wall = std::chrono::duration<double>(Clock::now() - start).count();
    const std::array<double, 4> out = {wall, r[0], r[1], r[2]};
    if (::write(fds[1], out.data(), sizeof out) != static_cast<ssize_t>(sizeof out)) ::_exit(3);
    ::_exit(0);
  }
  ::close(fds[1]);
  std::array<double, 4> in{};
  const ssize_t got = ::read(fds[0], in.data(), sizeof in);
  ::close(fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  if (got != static_cast<ssize_t>(sizeof in)) std::abort();
  return {in[0], in[1], in[2], in[3], std::chrono::duration<double>(Clock::now() - t0).count()};
}

void report(benchmark::State& state, const std::vector<ChildResult>& runs) {
  double wall = 0, sim_s = 0, acts = 0, parent = 0, solves = 0;
  for (const auto& r : runs) {
    solves += r.solves;
    wall += r.wall_s;
    sim_s += r.sim_s;
    acts += r.activations;
    parent += r.parent_s;
  }
  const auto n = static_cast<double>(runs.size());
  state.counters["sim_per_wall"] = sim_s / wall;
  state.counters["ns_per_act"] = wall / acts * 1e9;
  state.counters["activations"] = acts / n;
  state.counters["sim_ms"] = sim_s / n * 1e3;
  state.counters["fork_ms"] = parent / n * 1e3;
  state.counters["solves"] = solves / n;
}

void BM_SimMinimalSetup(benchmark::State& state) {
  const TimeNs sampling_us = state.range(0);
  const int iterations = static_cast<int>(state.range(1));
  std::vector<ChildResult> runs;
  for (auto _ : state) {
    const ChildResult r = in_child([&] {
      const sim::SimReport rep = sim::simulate(minimal_setup(sampling_us, iterations));
      return std::array<double, 3>{static_cast<double>(rep.end_ns) / 1e9,
                                   static_cast<double>(rep.activations),
                                   static_cast<double>(rep.memory_solves)};
    });
    state.SetIterationTime(r.wall_s);
    runs.push_back(r);
  }
  report(state, runs);
}
// {sampling period in us, RT jobs}: the minimal setup of the issue (1 ms), and a 100 us stress.
BENCHMARK(BM_SimMinimalSetup)
    ->Args({1000, 1})
    ->Args({1000, 10})
    ->Args({100, 10})
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);

// Bare SystemC: `procs` SC_METHODs doing nothing but re-triggering themselves every 10 us.
struct Idle : sc_core::sc_module {
  SC_HAS_PROCESS(Idle);
  explicit Idle(const sc_core::sc_module_name& n) : sc_core::sc_module(n) { SC_METHOD(tick); }
  void tick() {
    ++count;
    next_trigger(10, sc_core::SC_US);
  }
  static inline std::uint64_t count = 0;
};

void BM_BareScMethod(benchmark::State& state) {
  const int procs = static_cast<int>(state.range(0));
  std::vector<ChildResult> runs;
  for (auto _ : state) {
    const ChildResult r = in_child([&] {
      ::setenv("SC_COPYRIGHT_MESSAGE", "DISABLE", 1);
      std::vector<std::unique_ptr<Idle>> m;
      for (int i = 0; i < procs; ++i)
        m.push_back(std::make_unique<Idle>(("idle" + std::to_string(i)).c_str()));
      sc_core::sc_start(sc_core::sc_time(1.0, sc_core::SC_SEC));
      return std::array<double, 3>{1.0, static_cast<double>(Idle::count), 0.0};
    });
    state.SetIterationTime(r.wall_s);
    runs.push_back(r);
  }
  report(state, runs);
}
BENCHMARK(BM_BareScMethod)->Arg(1)->Arg(12)->UseManualTime()->Unit(benchmark::kMillisecond);

// One fixed point of the memory model (what a quantum boundary with a new demand costs; repeated
// demands are memoised by the memory system).
void BM_ContentionSolve(benchmark::State& state) {
  const sim::SimPlatform p = orin();
  const sim::ContentionModel m(p);
  const sim::WorkloadProfile br = profile("bandwidth_read");
  const sim::WorkloadProfile ms = profile("mser");
  std::vector<sim::CoreDemand> d;
  for (int i = 0; i < state.range(0); ++i) {
    const sim::WorkloadProfile& w = i % 2 ? ms : br;
    d.push_back({i / 4 % 3, &w.phases[0], &w, true, &w.phases[0]});
  }
  for (auto _ : state)
    benchmark::DoNotOptimize(m.solve(d));
}
BENCHMARK(BM_ContentionSolve)->Arg(2)->Arg(12)->Unit(benchmark::kMicrosecond);

}  // namespace

// The shared memory system of the simulated CPU complex (per-cluster L3, DRAM) as a SystemC
// module: it keeps the latencies every running core sees and re-solves them when the set of
// demands changes.
//
// Loosely-timed semantics with a quantum (scenario key sim.quantum_us): a core that changes what
// it runs (a phase boundary, a callback preempting its work, a throttle) switches its own rates at
// that exact time, computed with the latencies in force; the memory system re-solves the
// contention at the next quantum boundary, and only then do the co-runners see the change. So the
// cores interact through the shared resources at quantum granularity, while every per-core event
// (PMU reads, throttles, callbacks) keeps its exact time. Nothing is evaluated per cache line, and
// nothing runs at boundaries where no demand changed.
//
// The hit ratios come from each core's occupancy of its L3 (residency.h): a core that stops
// running loses its lines to its co-runners' insertions and refills them when it runs again.
// While some occupancy moves, the memory system also re-solves when one crosses a level of the
// capacity or reaches its target (at the quantum boundary after that time).
//
// Contract: created during elaboration; attach() every core before the simulation starts. Cores
// call mark_dirty() when their demand changes; resolve() calls Core::memory_changed() on each.
#pragma once

#include <cstdint>
#include <map>
#include <systemc>
#include <vector>

#include "kernel/runtime.h"
#include "platform/contention.h"
#include "platform/residency.h"

namespace rosguard::sim {

class Core;

class MemorySystem : public sc_core::sc_module {
 public:
  SC_HAS_PROCESS(MemorySystem);
  MemorySystem(const sc_core::sc_module_name& name, const SimPlatform& platform, TimeNs quantum_ns,
               Runtime& rt);

  // Returns the core's index in the memory state (its hit ratio).
  std::size_t attach(Core* core);
  // A core's demand changed: re-solve at the next quantum boundary (now, if on one).
  void mark_dirty();

  const MemoryState& state() const { return state_; }
  const ContentionModel& model() const { return model_; }
  CoreRates rates(std::size_t index, const Phase& phase, int cluster) const {
    const double hit =
        index < state_.l3_hit.size() ? state_.l3_hit[index] : 1.0 - phase.mrc.miss_ratio(0.0);
    const double slc = index < state_.slc_hit.size() ? state_.slc_hit[index] : 0.0;
    return model_.rates(phase, hit, cluster, state_, slc);
  }
  std::uint64_t solves() const { return solves_; }
  const L3Residency& residency() const { return residency_; }

 private:
  void resolve();
  void schedule_at(TimeNs boundary);

  ContentionModel model_;
  TimeNs quantum_ns_;
  Runtime& rt_;
  std::vector<Core*> cores_;
  L3Residency residency_;
  MemoryState state_;
  std::map<std::vector<std::uintptr_t>, MemoryState> memo_;
  std::vector<CoreDemand> demands_;  // scratch of resolve()
  std::vector<std::uintptr_t> key_;  // scratch of resolve()
  sc_core::sc_event ev_;
  TimeNs scheduled_at_ = -1;  // the pending re-solve (-1: none)
  std::uint64_t solves_ = 0;  // fixed points computed
};

}  // namespace rosguard::sim

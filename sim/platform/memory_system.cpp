#include "platform/memory_system.h"

#include <bit>
#include <cmath>

#include "platform/core.h"

namespace rosguard::sim {

MemorySystem::MemorySystem(const sc_core::sc_module_name& name, const SimPlatform& platform,
                           TimeNs quantum_ns, Runtime& rt)
    : sc_core::sc_module(name),
      model_(platform),
      quantum_ns_(std::max<TimeNs>(1, quantum_ns)),
      rt_(rt),
      residency_(model_, platform),
      state_(model_.unloaded()) {
  SC_METHOD(resolve);
  sensitive << ev_;
  dont_initialize();
}

std::size_t MemorySystem::attach(Core* core) {
  cores_.push_back(core);
  return cores_.size() - 1;
}

void MemorySystem::mark_dirty() {
  const TimeNs now = now_ns();
  schedule_at((now + quantum_ns_ - 1) / quantum_ns_ * quantum_ns_);
}

void MemorySystem::schedule_at(TimeNs boundary) {
  if (scheduled_at_ >= 0 && scheduled_at_ <= boundary) return;
  scheduled_at_ = boundary;  // an earlier notification overrides a pending later one
  const TimeNs now = now_ns();
  if (boundary <= now)
    ev_.notify(sc_core::SC_ZERO_TIME);
  else
    ev_.notify(to_sc(boundary - now));
}

void MemorySystem::resolve() {
  rt_.guarded([&] {
    scheduled_at_ = -1;
    const TimeNs now = now_ns();
    std::vector<CoreDemand>& demands = demands_;
    std::vector<std::uintptr_t>& key = key_;
    demands.clear();
    key.clear();
    for (Core* c : cores_) {
      const CoreDemand d = c->demand();
      demands.push_back(d);
      key.push_back(static_cast<std::uintptr_t>(d.cluster));
      key.push_back(reinterpret_cast<std::uintptr_t>(d.phase));
      key.push_back(reinterpret_cast<std::uintptr_t>(d.resident_phase));
      key.push_back(d.resident ? 1 : 0);
      key.push_back(reinterpret_cast<std::uintptr_t>(d.workload));
    }
    // Occupancies up to now; the hit ratios of the running cores are part of the key (the
    // others' do not enter the solution).
    residency_.advance(static_cast<double>(now), demands);
    const std::vector<double>& hits = residency_.hits();
    for (std::size_t i = 0; i < demands.size(); ++i)
      key.push_back(demands[i].phase ? std::bit_cast<std::uint64_t>(hits[i]) : 0);
    auto it = memo_.find(key);
    if (it == memo_.end()) {
      ++solves_;
      if (memo_.size() > 4096) memo_.clear();
      it = memo_.emplace(key, model_.solve(demands, hits)).first;
    }
    MemoryState next = it->second;
    next.l3_hit = hits;
    const double moves = residency_.set_rates(demands, next);
    if (moves >= 0.0) {
      const TimeNs at = now + std::max<TimeNs>(1, static_cast<TimeNs>(std::ceil(moves)));
      schedule_at((at + quantum_ns_ - 1) / quantum_ns_ * quantum_ns_);
    }
    if (next == state_) return;
    state_ = std::move(next);
    for (Core* c : cores_)
      c->memory_changed();
  });
}

}  // namespace rosguard::sim

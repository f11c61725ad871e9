#include "platform/memory_system.h"

#include <bit>

#include "platform/core.h"

namespace rosguard::sim {

MemorySystem::MemorySystem(const sc_core::sc_module_name& name, const SimPlatform& platform,
                           TimeNs quantum_ns, Runtime& rt)
    : sc_core::sc_module(name),
      model_(platform),
      quantum_ns_(std::max<TimeNs>(1, quantum_ns)),
      rt_(rt),
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
  if (scheduled_) return;
  scheduled_ = true;
  const TimeNs now = now_ns();
  const TimeNs boundary = (now + quantum_ns_ - 1) / quantum_ns_ * quantum_ns_;
  if (boundary == now)
    ev_.notify(sc_core::SC_ZERO_TIME);
  else
    ev_.notify(to_sc(boundary - now));
}

void MemorySystem::resolve() {
  rt_.guarded([&] {
    scheduled_ = false;
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
      key.push_back(static_cast<std::uintptr_t>(std::bit_cast<std::uint64_t>(d.footprint_kb)));
      key.push_back(static_cast<std::uintptr_t>(std::bit_cast<std::uint64_t>(d.l3_hit)));
    }
    auto it = memo_.find(key);
    if (it == memo_.end()) {
      ++solves_;
      if (memo_.size() > 4096) memo_.clear();
      it = memo_.emplace(key, model_.solve(demands)).first;
    }
    if (it->second == state_) return;
    state_ = it->second;
    for (Core* c : cores_)
      c->memory_changed();
  });
}

}  // namespace rosguard::sim

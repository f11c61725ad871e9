#include "hw/pmc_source/pmc_source.h"

#include <algorithm>
#include <stdexcept>

#include "core/error.h"
#include "hw/pmc_source/overflow.h"

namespace rosguard::hw {

std::string PmcTarget::describe() const {
  switch (kind) {
    case Kind::Thread:
      return pid == 0 ? "the calling thread" : "thread " + std::to_string(pid);
    case Kind::Process:
      return "process " + std::to_string(pid) + " and its children";
    case Kind::Cpu:
      return "cpu " + std::to_string(cpu);
  }
  return "?";
}

std::optional<std::string> PmcSource::probe(const std::string& event) const {
  try {
    open({event}, PmcTarget{});
    return std::nullopt;
  } catch (const RunError& e) {
    return std::string(e.what());
  }
}

std::optional<std::string> PmcSource::overflow_unavailable(const std::vector<std::string>&) const {
  return "the " + std::string(name()) + " source has no overflow counters";
}

std::unique_ptr<OverflowCounters> PmcSource::open_overflow(const std::vector<std::string>&,
                                                           const PmcTarget&) const {
  throw ContractError("the " + std::string(name()) + " source has no overflow counters");
}

bool PmcSource::provides(std::string_view event) const {
  const auto e = events();
  return std::find(e.begin(), e.end(), event) != e.end();
}

void register_builtin(PmcSourceRegistry& r) {
  r.add({"perf",
         "hardware PMU events through perf_event_open groups (ARMv8 PMUv3 raw codes on aarch64, "
         "the nearest generic events on x86)",
         make_perf_source});
  r.add({"software",
         "perf software events (task_clock, context_switches, cpu_migrations, page_faults); the "
         "regulation metric becomes a time-based budget",
         make_software_source});
  r.add({"instrumented",
         "cache lines counted by the built-in workloads and published through shared atomics",
         make_instrumented_source});
}

}  // namespace rosguard::hw

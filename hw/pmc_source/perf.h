// perf_event_open groups, shared by the perf (hardware) and software sources.
//
// Contract: PerfGroup owns every fd (RAII, move-only), opens the first event as the group
// leader with PERF_FORMAT_GROUP | TOTAL_TIME_ENABLED | TOTAL_TIME_RUNNING, retries EINTR, and
// throws RunError naming the event, its code, the target and the errno when an event cannot be
// opened. Multiplexed values are returned raw with their times; metric.h scales them.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "hw/pmc_source/overflow.h"
#include "hw/pmc_source/perf_events.h"
#include "hw/pmc_source/pmc_source.h"

namespace rosguard::hw {

using NamedEvent = std::pair<std::string, PerfEventCode>;

// Opens `events` as one group on `target`. Throws RunError.
std::unique_ptr<CounterGroup> open_perf_group(const std::vector<NamedEvent>& events,
                                              const PmcTarget& target);

// One sampling event per entry on a thread target, disarmed (overflow.h). Throws RunError.
std::unique_ptr<OverflowCounters> open_perf_overflow(const std::vector<NamedEvent>& events,
                                                     const PmcTarget& target);
// Whether this host gives overflow counters for `events`: opens them on the calling thread and
// routes their signal to it (never armed); empty if that works, else why not.
std::optional<std::string> probe_perf_overflow(const std::vector<NamedEvent>& events);

// The common ARMv8 PMUv3 events (numbers below 0x40) that the CPUs' PMUs implement, as the kernel
// lists them in sysfs: DEVICES/armv8_*/events/ holds one file ("event=0x0017") per event the
// PMU's PMCEID registers advertise. A raw code outside them still opens with perf_event_open
// (the kernel passes raw codes through) and then counts 0 (seen under qemu-system-aarch64,
// docs/orin.md). With several such PMUs (heterogeneous cores) the events every one implements.
struct Armv8PmuEvents {
  std::set<std::uint64_t> codes;
  std::string where;  // the events/ folder(s) read
};
// nullopt where DEVICES lists no armv8_* PMU (x86, or a kernel without the PMUv3 driver).
std::optional<Armv8PmuEvents> armv8_pmu_events(
    const std::string& devices = "/sys/bus/event_source/devices");
// Why `code` would count 0 on PMUs that implement `implemented`: a raw common event they do not
// list. nullopt when they list it, or say nothing about it (another type, a code from 0x40, no
// armv8_* PMU).
std::optional<std::string> pmu_lacks(const PerfEventCode& code,
                                     const std::optional<Armv8PmuEvents>& implemented);

// A source whose counters are perf events (the perf and the software sources): groups, overflow
// counters and their probe through the functions above; each source names its events' codes.
class PerfEventSource : public PmcSource {
 public:
  bool counts_processes() const override { return true; }
  std::unique_ptr<CounterGroup> open(const std::vector<std::string>& events,
                                     const PmcTarget& target) const override;
  std::optional<std::string> overflow_unavailable(
      const std::vector<std::string>& events) const override;
  std::unique_ptr<OverflowCounters> open_overflow(const std::vector<std::string>& events,
                                                  const PmcTarget& target) const override;

 protected:
  // The perf code of each event. Throws RunError for an event this source has no code for.
  virtual std::vector<NamedEvent> named(const std::vector<std::string>& events) const = 0;
};

}  // namespace rosguard::hw

// PMC sources: where the regulator's counter values come from on a real machine.
//
// Contract:
// - A PmcSource is chosen per run by hw.pmc_source (auto | perf | software | instrumented). It
//   is created on the engine's thread and is immutable afterwards; open() may be called from any
//   thread (external commands open their counters from the NCT thread before exec).
// - A CounterGroup is one set of events counted together on one target. read() fills cumulative
//   values in the order the events were given, each with time enabled / running so multiplexed
//   counters can be scaled (metric.h). read() is safe from any thread; the regulator's two
//   readers (the PMC callback or the controller, and the engine's window snapshots) may call it
//   concurrently.
// - Failures are RunError naming the event, the target and the errno.
// - Overflow counters (MemGuard's interrupt, hw/pmc_source/overflow.h) come from the perf and
//   software sources, on a thread target only (an inherited (process) event cannot be sampled as
//   one count over the process and its children), and from the instrumented source, on a
//   built-in workload.
#pragma once

#include <sys/types.h>

#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/registry.h"
#include "metric/metric.h"

namespace rosguard::hw {

struct WorkCounters;
class OverflowCounters;

// What a group counts.
struct PmcTarget {
  enum class Kind { Thread, Process, Cpu };
  Kind kind = Kind::Thread;
  pid_t pid = 0;  // thread id (Thread) or process id (Process); 0 = the calling thread
  int cpu = -1;   // Cpu: the core counted
  // Process targets opened before exec start counting at exec (perf enable_on_exec).
  bool enable_on_exec = false;
  // Instrumented source: the counters the built-in workload publishes.
  const WorkCounters* work = nullptr;

  std::string describe() const;
};

class CounterGroup {
 public:
  virtual ~CounterGroup() = default;
  virtual std::size_t size() const = 0;
  // Cumulative values, one per event, in the order given to open().
  virtual void read(std::span<CounterValue> out) = 0;
};

class PmcSource {
 public:
  virtual ~PmcSource() = default;
  virtual std::string_view name() const = 0;
  // Empty when the source works on this host; otherwise why not (event, errno).
  virtual std::optional<std::string> unavailable_reason() const = 0;
  // Events this source can count here (empty if unavailable).
  virtual std::vector<std::string> events() const = 0;
  bool provides(std::string_view event) const;
  // Whether it can count an external process (the instrumented source cannot).
  virtual bool counts_processes() const = 0;
  // Opens `events` on `target` as one group. Throws RunError naming the event and errno.
  virtual std::unique_ptr<CounterGroup> open(const std::vector<std::string>& events,
                                             const PmcTarget& target) const = 0;
  // Overflow sampling (overflow.h): why this source cannot give overflow counters for `events`
  // on this host (empty when it can; the perf-based sources try it on the calling thread). The
  // default: none.
  virtual std::optional<std::string> overflow_unavailable(
      const std::vector<std::string>& events) const;
  // Overflow counters for `events` on a thread target, disarmed. Throws RunError.
  virtual std::unique_ptr<OverflowCounters> open_overflow(const std::vector<std::string>& events,
                                                          const PmcTarget& target) const;

 protected:
  // unavailable_reason() by trial: opens `event` on the calling thread; empty if that works,
  // else the open's error.
  std::optional<std::string> probe(const std::string& event) const;
};

struct PmcSourceInfo {
  std::string name;
  std::string description;
  std::function<std::unique_ptr<PmcSource>()> make;
};

// PMC sources by name.
class PmcSourceRegistry : public Registry<PmcSourceInfo> {
 public:
  PmcSourceRegistry() : Registry("pmc source") {}
};

// Adds perf, software and instrumented.
void register_builtin(PmcSourceRegistry& registry);

std::unique_ptr<PmcSource> make_perf_source();          // hardware events via perf_event_open
std::unique_ptr<PmcSource> make_software_source();      // perf software events
std::unique_ptr<PmcSource> make_instrumented_source();  // counts published by built-in workloads

// The software source's standard group: read as one 4-event group by the PMC callback.
const std::vector<std::string>& software_group_events();

}  // namespace rosguard::hw

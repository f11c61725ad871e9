// The software source: perf software events through the same perf_event_open group code, so the
// perf path runs on machines without a hardware PMU. It has no bandwidth events: the engine
// regulates with a time-based budget on task_clock (see hw/backend.cpp, plan_metric).
#include <memory>

#include "core/error.h"
#include "hw/pmc_source/perf.h"

namespace rosguard::hw {
namespace {

class SoftwareSource : public PmcSource {
 public:
  std::string_view name() const override { return "software"; }

  std::optional<std::string> unavailable_reason() const override { return probe("task_clock"); }

  std::vector<std::string> events() const override {
    return unavailable_reason() ? std::vector<std::string>{} : software_event_names();
  }

  bool counts_processes() const override { return true; }

  std::unique_ptr<CounterGroup> open(const std::vector<std::string>& events,
                                     const PmcTarget& target) const override {
    return open_perf_group(named(events), target);
  }

  std::optional<std::string> overflow_unavailable(
      const std::vector<std::string>& events) const override {
    if (auto why = unavailable_reason()) return why;
    try {
      return probe_perf_overflow(named(events));
    } catch (const RunError& e) {
      return std::string(e.what());
    }
  }

  std::unique_ptr<OverflowCounters> open_overflow(const std::vector<std::string>& events,
                                                  const PmcTarget& target) const override {
    return open_perf_overflow(named(events), target);
  }

 private:
  static std::vector<NamedEvent> named(const std::vector<std::string>& events) {
    std::vector<NamedEvent> out;
    for (const auto& e : events) {
      auto code = software_event(e);
      if (!code) throw RunError("software source: '" + e + "' is not a perf software event");
      out.emplace_back(e, *code);
    }
    return out;
  }
};

}  // namespace

const std::vector<std::string>& software_group_events() {
  static const std::vector<std::string> events = {"task_clock", "context_switches",
                                                  "cpu_migrations", "page_faults"};
  return events;
}

std::unique_ptr<PmcSource> make_software_source() {
  return std::make_unique<SoftwareSource>();
}

}  // namespace rosguard::hw

// The software source: perf software events through the same perf_event_open group code, so the
// perf path runs on machines without a hardware PMU. It has no bandwidth events: the engine
// regulates with a time-based budget on task_clock (see hw/backend.cpp, plan_metric).
#include <memory>

#include "core/error.h"
#include "hw/pmc_source/perf.h"

namespace rosguard::hw {
namespace {

class SoftwareSource : public PerfEventSource {
 public:
  std::string_view name() const override { return "software"; }

  std::optional<std::string> unavailable_reason() const override { return probe("task_clock"); }

  std::vector<std::string> events() const override {
    return unavailable_reason() ? std::vector<std::string>{} : software_event_names();
  }

 protected:
  std::vector<NamedEvent> named(const std::vector<std::string>& events) const override {
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

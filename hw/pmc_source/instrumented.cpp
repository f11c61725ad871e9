// The instrumented source: the built-in workloads count the cache lines they touch and publish
// the counts through shared atomics (work_counters.h). Gives a real bandwidth metric on machines
// without a hardware PMU. Mapping to the metric's event names:
//   l2d_cache_refill = lines read + lines written (a store to a line first allocates it)
//   l2d_cache_wb     = lines written (every dirty line is eventually written back)
// Every touched line is counted, as if no line hit in the private caches: the bandwidth kernels
// stream over their working set, so this is the traffic they ask of the level below.
// There is no cycle counter: Eq. 1 is evaluated with cycles = elapsed time x frequency, i.e.
// bandwidth = bytes / elapsed time.
#include <memory>

#include "core/error.h"
#include "hw/common/clock.h"
#include "hw/pmc_source/pmc_source.h"
#include "hw/workload/work_counters.h"

namespace rosguard::hw {
namespace {

enum class Field { Refill, Wb };

class InstrumentedGroup : public CounterGroup {
 public:
  InstrumentedGroup(const WorkCounters* work, std::vector<Field> fields)
      : work_(work), fields_(std::move(fields)), opened_(now_ns()) {}

  std::size_t size() const override { return fields_.size(); }

  void read(std::span<CounterValue> out) override {
    const auto elapsed = static_cast<std::uint64_t>(now_ns() - opened_);
    const std::uint64_t r = work_->lines_read.load(std::memory_order_relaxed);
    const std::uint64_t w = work_->lines_written.load(std::memory_order_relaxed);
    const std::size_t k = std::min(out.size(), fields_.size());
    for (std::size_t i = 0; i < k; ++i)
      out[i] = {fields_[i] == Field::Refill ? r + w : w, elapsed, elapsed};
  }

 private:
  const WorkCounters* work_;
  std::vector<Field> fields_;
  TimeNs opened_;
};

class InstrumentedSource : public PmcSource {
 public:
  std::string_view name() const override { return "instrumented"; }
  std::optional<std::string> unavailable_reason() const override { return std::nullopt; }
  std::vector<std::string> events() const override { return {"l2d_cache_refill", "l2d_cache_wb"}; }
  bool counts_processes() const override { return false; }

  std::unique_ptr<CounterGroup> open(const std::vector<std::string>& events,
                                     const PmcTarget& target) const override {
    if (!target.work)
      throw RunError(
          "instrumented source: " + target.describe() +
          " is not a built-in workload (only built-in workloads publish their cache lines)");
    std::vector<Field> fields;
    for (const auto& e : events) {
      if (e == "l2d_cache_refill")
        fields.push_back(Field::Refill);
      else if (e == "l2d_cache_wb")
        fields.push_back(Field::Wb);
      else
        throw RunError("instrumented source: event '" + e +
                       "' is not counted (it provides l2d_cache_refill, l2d_cache_wb)");
    }
    return std::make_unique<InstrumentedGroup>(target.work, std::move(fields));
  }
};

}  // namespace

std::unique_ptr<PmcSource> make_instrumented_source() {
  return std::make_unique<InstrumentedSource>();
}

}  // namespace rosguard::hw

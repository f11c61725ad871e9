// The instrumented source: the built-in workloads count the cache lines they touch and publish
// the counts through shared atomics (work_counters.h). Gives a real bandwidth metric on machines
// without a hardware PMU. Mapping to the metric's event names:
//   l2d_cache_refill = lines read + lines written (a store to a line first allocates it)
//   l2d_cache_wb     = lines written (every dirty line is eventually written back)
// Every touched line is counted, as if no line hit in the private caches: the bandwidth kernels
// stream over their working set, so this is the traffic they ask of the level below.
// There is no cycle counter: Eq. 1 is evaluated with cycles = elapsed time x frequency, i.e.
// bandwidth = bytes / elapsed time.
// Overflow counters (MemGuard's interrupt): the workloads' overflow watches, which the workload
// thread checks after each chunk of 64 lines (so up to a chunk late) and which queue the
// overflow signal to the controller thread themselves (overflow.h, work_counters.h).
#include <algorithm>
#include <memory>

#include "core/error.h"
#include "hw/common/clock.h"
#include "hw/common/sys.h"
#include "hw/pmc_source/overflow.h"
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

// The watch of each field: refills are lines read + written, write-backs lines written.
std::size_t watch_of(Field f) {
  return f == Field::Refill ? WorkCounters::kRefillWatch : WorkCounters::kWbWatch;
}

class InstrumentedOverflow final : public OverflowCounters {
 public:
  InstrumentedOverflow(const WorkCounters* work, std::vector<Field> fields,
                       std::vector<std::string> names)
      : OverflowCounters(std::move(names)),
        work_(work),
        fields_(std::move(fields)),
        slots_(fields_.size(), -1) {
    for (std::size_t i = 0; i < fields_.size(); ++i)
      for (std::size_t j = 0; j < i; ++j)
        if (fields_[j] == fields_[i])
          throw RunError("instrumented source: overflow counters for '" + names_[i] +
                         "' twice on one workload");
  }

  ~InstrumentedOverflow() override {
    for (std::size_t i = 0; i < fields_.size(); ++i) {
      OverflowWatch& w = watch(i);
      work_->watching.fetch_and(~(std::uint32_t{1} << watch_of(fields_[i])),
                                std::memory_order_acq_rel);
      w.at.store(OverflowWatch::kNever, std::memory_order_release);
      w.slot.store(-1, std::memory_order_relaxed);
      release_queued_slot(slots_[i]);
    }
  }

  void claim(OverflowSink& sink, std::size_t entity) override {
    for (std::size_t i = 0; i < fields_.size(); ++i) {
      if (slots_[i] < 0) slots_[i] = take_queued_slot(sink, entity, i);
      OverflowWatch& w = watch(i);
      w.tid.store(current_tid(), std::memory_order_relaxed);
      w.sig.store(overflow_signal(), std::memory_order_relaxed);
      w.slot.store(slots_[i], std::memory_order_release);
    }
  }

  void arm(std::span<const std::uint64_t> periods) override {
    for (std::size_t i = 0; i < fields_.size(); ++i) {
      const std::uint64_t p = i < periods.size() ? periods[i] : 0;
      OverflowWatch& w = watch(i);
      // The period runs from the count now, as a new perf period does; the watch is checked
      // once per chunk, so no period is shorter (as a clock event's 10 us floor).
      periods_[i] = p == 0 ? 0 : std::max(p, WorkCounters::kChunkLines);
      const std::uint32_t bit = std::uint32_t{1} << watch_of(fields_[i]);
      if (p == 0) {
        work_->watching.fetch_and(~bit, std::memory_order_acq_rel);
        w.at.store(OverflowWatch::kNever, std::memory_order_release);
        continue;
      }
      w.period.store(periods_[i], std::memory_order_relaxed);
      w.at.store(work_->watched(watch_of(fields_[i])) + periods_[i], std::memory_order_release);
      work_->watching.fetch_or(bit, std::memory_order_acq_rel);
    }
  }

 private:
  OverflowWatch& watch(std::size_t i) const { return work_->watches[watch_of(fields_[i])]; }

  const WorkCounters* work_;
  std::vector<Field> fields_;
  std::vector<int> slots_;  // in the overflow handler's table; -1 none
};

class InstrumentedSource : public PmcSource {
 public:
  std::string_view name() const override { return "instrumented"; }
  std::optional<std::string> unavailable_reason() const override { return std::nullopt; }
  std::vector<std::string> events() const override { return {"l2d_cache_refill", "l2d_cache_wb"}; }
  bool counts_processes() const override { return false; }

  std::unique_ptr<CounterGroup> open(const std::vector<std::string>& events,
                                     const PmcTarget& target) const override {
    return std::make_unique<InstrumentedGroup>(work_of(target), fields(events));
  }

  std::optional<std::string> overflow_unavailable(
      const std::vector<std::string>& events) const override {
    try {
      fields(events);
      return std::nullopt;
    } catch (const RunError& e) {
      return std::string(e.what());
    }
  }

  std::unique_ptr<OverflowCounters> open_overflow(const std::vector<std::string>& events,
                                                  const PmcTarget& target) const override {
    return std::make_unique<InstrumentedOverflow>(work_of(target), fields(events), events);
  }

 private:
  static const WorkCounters* work_of(const PmcTarget& target) {
    if (!target.work)
      throw RunError(
          "instrumented source: " + target.describe() +
          " is not a built-in workload (only built-in workloads publish their cache lines)");
    return target.work;
  }

  static std::vector<Field> fields(const std::vector<std::string>& events) {
    std::vector<Field> out;
    for (const auto& e : events) {
      if (e == "l2d_cache_refill")
        out.push_back(Field::Refill);
      else if (e == "l2d_cache_wb")
        out.push_back(Field::Wb);
      else
        throw RunError("instrumented source: event '" + e +
                       "' is not counted (it provides l2d_cache_refill, l2d_cache_wb)");
    }
    return out;
  }
};

}  // namespace

std::unique_ptr<PmcSource> make_instrumented_source() {
  return std::make_unique<InstrumentedSource>();
}

}  // namespace rosguard::hw

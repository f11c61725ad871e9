// Messages on the topics between nodes, and what node threads record for the engine.
//
// Every stamp is CLOCK_MONOTONIC ns (hw/common/clock.h), so stamps taken on different cores can
// be subtracted (activation delay = THR entered - sample published / read).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/types.h"
#include "metric/metric.h"

namespace rosguard::hw {

inline constexpr std::size_t kMaxGroupEvents = 8;

// nRT node (PMC callback) -> controller, self-sampling.
struct SampleMsg {
  std::size_t entity = 0;
  TimeNs t_published = 0;
  std::uint8_t count = 0;
  std::array<CounterValue, kMaxGroupEvents> counters{};
};

// RT node -> controller: the enable / disable signal.
struct RtEventMsg {
  std::size_t rt = 0;
  bool started = false;
  TimeNs t = 0;
  std::uint64_t writer = 0;  // DDS: the sender's publication handle; 0 in process
};

// Controller -> one nRT node's CFB callback (the control topic).
struct ControlMsg {
  enum class Kind : std::uint8_t { Command, Keepalive };
  Kind kind = Kind::Command;
  Command command = Command::Off;
  TimeNs t_cause = 0;  // the sample that caused it: published (self) or read (external)
};

// A trace event recorded by a node thread, emitted by the engine's thread after the run (the
// TraceSink is not thread-safe). Strings point at node-owned names or literals.
struct TraceRecord {
  enum class Kind : std::uint8_t { Span, Counter, Instant };
  Kind kind = Kind::Instant;
  TimeNs a = 0, b = 0;
  int core = 0;
  const std::string* track = nullptr;
  const char* name = "";
  double value = 0.0;
};

// Pre-reserved so recording in a hot path does not allocate in the common case.
class TraceLog {
 public:
  explicit TraceLog(bool enabled, std::size_t reserve = 1 << 14) : enabled_(enabled) {
    if (enabled_) records_.reserve(reserve);
  }
  void span(TimeNs a, TimeNs b, int core, const std::string* track, const char* name) {
    if (enabled_) records_.push_back({TraceRecord::Kind::Span, a, b, core, track, name, 0.0});
  }
  void counter(TimeNs t, int core, const char* name, double v) {
    if (enabled_) records_.push_back({TraceRecord::Kind::Counter, t, t, core, nullptr, name, v});
  }
  void instant(TimeNs t, int core, const std::string* track, const char* name) {
    if (enabled_) records_.push_back({TraceRecord::Kind::Instant, t, t, core, track, name, 0.0});
  }
  const std::vector<TraceRecord>& records() const { return records_; }

 private:
  bool enabled_;
  std::vector<TraceRecord> records_;
};

}  // namespace rosguard::hw

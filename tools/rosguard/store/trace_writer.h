// --trace: Chrome trace event JSON (opens in Perfetto / chrome://tracing). One "process" per
// point and repetition, one "thread" per (core, track).
//
// Contract: a ChromeTrace collects one task's events (in the process that runs the task);
// take() hands them over as JSON, which the runner gathers and writes with write_trace().
#pragma once

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "backend/backend.h"

namespace rosguard {

class ChromeTrace : public TraceSink {
 public:
  // `pid`: the trace "process" of this point and repetition (unique within a run).
  explicit ChromeTrace(int pid) : pid_(pid) {}

  void span(TimeNs begin, TimeNs end, int core, std::string_view track,
            std::string_view name) override;
  void counter(TimeNs t, int core, std::string_view name, double value) override;
  void instant(TimeNs t, int core, std::string_view track, std::string_view name) override;

  // The metadata (process and thread names) and every event so far; clears the events.
  nlohmann::json take(const std::string& process_name);

 private:
  int tid(int core, std::string_view track);

  int pid_;
  std::vector<nlohmann::json> events_;
  std::map<std::pair<int, std::string>, int> tids_;
};

// Adds `events` to the trace file at `path` (created when missing), keeping the events other
// invocations (shards, resumed runs) wrote there. The caller holds the results folder's lock.
void write_trace(const std::filesystem::path& path, const nlohmann::json& events);

}  // namespace rosguard

#include "store/trace_writer.h"

#include <algorithm>

#include "load/files.h"

namespace rosguard {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

double us(TimeNs t) {
  return static_cast<double>(t) / 1e3;
}

}  // namespace

void ChromeTrace::span(TimeNs begin, TimeNs end, int core, std::string_view track,
                       std::string_view name) {
  events_.push_back({{"ph", "X"},
                     {"pid", pid_},
                     {"tid", tid(core, track)},
                     {"name", name},
                     {"ts", us(begin)},
                     {"dur", us(std::max<TimeNs>(0, end - begin))}});
}

void ChromeTrace::counter(TimeNs t, int core, std::string_view name, double value) {
  events_.push_back({{"ph", "C"},
                     {"pid", pid_},
                     {"name", "core " + std::to_string(core) + " " + std::string(name)},
                     {"ts", us(t)},
                     {"args", {{std::string(name), value}}}});
}

void ChromeTrace::instant(TimeNs t, int core, std::string_view track, std::string_view name) {
  events_.push_back({{"ph", "i"},
                     {"s", "t"},
                     {"pid", pid_},
                     {"tid", tid(core, track)},
                     {"name", name},
                     {"ts", us(t)}});
}

json ChromeTrace::take(const std::string& process_name) {
  json out = json::array();
  out.push_back(
      {{"ph", "M"}, {"pid", pid_}, {"name", "process_name"}, {"args", {{"name", process_name}}}});
  out.push_back({{"ph", "M"},
                 {"pid", pid_},
                 {"name", "process_sort_index"},
                 {"args", {{"sort_index", pid_}}}});
  for (const auto& [key, id] : tids_)
    out.push_back({{"ph", "M"},
                   {"pid", pid_},
                   {"tid", id},
                   {"name", "thread_name"},
                   {"args", {{"name", "core " + std::to_string(key.first) + ": " + key.second}}}});
  for (auto& e : events_)
    out.push_back(std::move(e));
  events_.clear();
  return out;
}

int ChromeTrace::tid(int core, std::string_view track) {
  const auto key = std::make_pair(core, std::string(track));
  auto it = tids_.find(key);
  if (it != tids_.end()) return it->second;
  const int id = core * 100 + static_cast<int>(tids_.size()) + 1;
  tids_[key] = id;
  return id;
}

void write_trace(const fs::path& path, const json& events) {
  std::error_code ec;
  json all = json::array();
  if (fs::exists(path, ec)) {
    const json old = json::parse(read_file(path), nullptr, false);
    if (old.is_object() && old.contains("traceEvents") && old["traceEvents"].is_array())
      all = old["traceEvents"];
  }
  for (const auto& e : events)
    all.push_back(e);
  write_file_atomic(path, json{{"traceEvents", all}, {"displayTimeUnit", "ms"}}.dump() + "\n");
}

}  // namespace rosguard

#include "hw/topic/dds/cyclone_log.h"

#include <dds/dds.h>
#include <time.h>

namespace rosguard::dds {

namespace {

std::int64_t monotonic_ns() {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

void sink(void* self, const dds_log_data_t* d) {
  // The message (the sink gets it without Cyclone's header), without its newline.
  std::string_view m(d->message, d->size);
  while (!m.empty() && (m.back() == '\n' || m.back() == ' '))
    m.remove_suffix(1);
  static_cast<LimitedCycloneLog*>(self)->take(d->file ? d->file : "", d->line, m, monotonic_ns());
}

// The kind of a line (see the header): its place in Cyclone's source and its message without
// numbers and packet dumps (`<...>`).
std::string kind(const std::string& file, std::uint32_t line, std::string_view message) {
  std::string k = file + ":" + std::to_string(line) + ":";
  int depth = 0;
  for (const char c : message) {
    if (c == '<') ++depth;
    if (depth == 0 && !(c >= '0' && c <= '9')) k += c;
    if (c == '>' && depth > 0) --depth;
  }
  return k;
}

}  // namespace

LimitedCycloneLog::LimitedCycloneLog(Write write, std::int64_t every_ns)
    : write_(std::move(write)), every_ns_(every_ns) {
  dds_set_log_sink(&sink, this);
}

LimitedCycloneLog::~LimitedCycloneLog() {
  dds_set_log_sink(nullptr, nullptr);
}

void LimitedCycloneLog::take(const std::string& file, std::uint32_t line, std::string_view message,
                             std::int64_t now_ns) {
  const std::lock_guard lock(lock_);
  // Forgotten kinds keep their lines left out in left_out_.
  if (repeats_.size() >= kMaxKinds)
    std::erase_if(repeats_, [&](const auto& r) { return now_ns - r.second.last_ns >= every_ns_; });
  Repeat& r =
      repeats_.try_emplace(kind(file, line, message), Repeat{now_ns, 0, false}).first->second;
  if (now_ns - window_start_ns_ >= every_ns_) {
    window_start_ns_ = now_ns;
    window_lines_ = 0;
  }
  if ((r.seen && now_ns - r.last_ns < every_ns_) || window_lines_ >= kBurst) {
    ++r.left_out;
    ++left_out_;
    return;
  }
  std::string text = "cyclone: " + std::string(message);
  if (r.left_out > 0)
    text += " (and " + std::to_string(r.left_out) + " more like it in the last " +
            std::to_string((now_ns - r.last_ns) / 1'000'000'000) + " s, not logged)";
  r = {now_ns, 0, true};
  ++window_lines_;
  ++written_;
  write_(text);
}

std::uint64_t LimitedCycloneLog::written() const {
  const std::lock_guard lock(lock_);
  return written_;
}

std::uint64_t LimitedCycloneLog::left_out() const {
  const std::lock_guard lock(lock_);
  return left_out_;
}

}  // namespace rosguard::dds

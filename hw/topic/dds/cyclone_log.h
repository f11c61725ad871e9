// Cyclone DDS's own log through a rate limit, for a daemon whose log must stay bounded.
//
// Cyclone writes its warnings and errors to stderr, one line per event: a malformed datagram
// sent to a participant's port gives a ~270-byte "malformed packet received" line, so a flood of
// junk from anyone who reaches the port floods the log (20,000 datagrams: +5.6 MB). While a
// LimitedCycloneLog lives, Cyclone's log lines (its log categories: fatal, error, warning, info;
// never its tracing) go to `write` instead, each kind of line at most once per `every_ns`, the
// next one of its kind saying how many were left out. A kind is the place in Cyclone's source and
// the message without its numbers and packet dumps (`<...>`): junk datagrams are one kind, a
// refused handshake is a kind per certificate subject. Over all kinds, at most kBurst lines per
// `every_ns` are written (distinct junk cannot flood the log either), and at most kMaxKinds are
// remembered (quiet ones are forgotten first).
//
// Contract: process-wide (Cyclone's log sink is global): at most one at a time; construct it
// before the first DDS entity, so that no line escapes it. `write` is called from Cyclone's
// threads, one call at a time (under the limiter's lock), with the message (no time stamp, no
// newline). Destruction restores Cyclone's default sink and returns once no call is running.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <string_view>

namespace rosguard::dds {

class LimitedCycloneLog {
 public:
  static constexpr std::uint64_t kBurst = 10;
  static constexpr std::size_t kMaxKinds = 256;
  using Write = std::function<void(const std::string& line)>;
  LimitedCycloneLog(Write write, std::int64_t every_ns);
  ~LimitedCycloneLog();
  LimitedCycloneLog(const LimitedCycloneLog&) = delete;
  LimitedCycloneLog& operator=(const LimitedCycloneLog&) = delete;

  // Lines written and left out so far.
  std::uint64_t written() const;
  std::uint64_t left_out() const;

  // What the sink does with one line from `file`:`line` at monotonic time `now_ns` (public for
  // tests: the sink calls it with Cyclone's data).
  void take(const std::string& file, std::uint32_t line, std::string_view message,
            std::int64_t now_ns);

 private:
  struct Repeat {
    std::int64_t last_ns = 0;  // last written; first met until then
    std::uint64_t left_out = 0;
    bool seen = false;  // written once
  };
  Write write_;
  std::int64_t every_ns_;
  mutable std::mutex lock_;
  std::map<std::string, Repeat> repeats_;  // by kind
  std::int64_t window_start_ns_ = 0;       // of the kBurst budget
  std::uint64_t window_lines_ = 0;
  std::uint64_t written_ = 0, left_out_ = 0;
};

}  // namespace rosguard::dds

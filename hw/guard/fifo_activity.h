// An ActivitySource for machines and scripts without DDS: lines `<rt name> 1|0|true|false` written
// to a named pipe (created when missing). `echo "planner 1" > /run/rosguard/activity`.
//
// Contract: start() opens the pipe (read-write, so that writers come and go without EOF) and
// starts one reader thread, the only caller of the signal callback; stop() wakes and joins it.
// An unknown name or a malformed line is reported through `on_bad_line` (from the reader thread)
// and ignored. Every writer of the pipe is one publisher ("the named pipe <path>"): a pipe does
// not say who wrote a line.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "hw/common/sys.h"
#include "hw/guard/guard.h"

namespace rosguard::hw {

class FifoActivity : public ActivitySource {
 public:
  explicit FifoActivity(std::string path, std::function<void(const std::string&)> on_bad_line = {});
  ~FifoActivity() override;
  std::string describe() const override { return "lines '<name> 1|0' on the named pipe " + path_; }
  void start(const std::vector<std::string>& rt_names, Signal signal) override;
  void stop() override;

 private:
  void main();
  std::string path_;
  std::function<void(const std::string&)> on_bad_line_;
  std::vector<std::string> names_;
  Signal signal_;
  Fd fd_, stop_fd_;
  std::thread thread_;
};

}  // namespace rosguard::hw

// Small RAII wrappers and host facts for the hw backend.
//
// Contract: Fd is move-only and closes on destruction; errors are reported as RunError with the
// call and the errno name. Host queries read /proc and /sys and never modify anything.
#pragma once

#include <sys/types.h>

#include <string>
#include <vector>

namespace rosguard::hw {

// "ENOENT (No such file or directory)".
std::string errno_text(int err);

class Fd {
 public:
  Fd() = default;
  explicit Fd(int fd) : fd_(fd) {}
  ~Fd() { reset(); }
  Fd(Fd&& o) noexcept : fd_(o.release()) {}
  Fd& operator=(Fd&& o) noexcept {
    if (this != &o) {
      reset();
      fd_ = o.release();
    }
    return *this;
  }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;

  int get() const { return fd_; }
  bool valid() const { return fd_ >= 0; }
  int release() {
    const int f = fd_;
    fd_ = -1;
    return f;
  }
  void reset();

 private:
  int fd_ = -1;
};

pid_t current_tid();

// CPUs this process may run on (online and in its affinity mask), ascending. While rosguard's
// own threads are pinned away from the measured cores (hw/housekeeping.h), the mask from before.
std::vector<int> usable_cpus();
// Set by hw/housekeeping.h's pin (the mask before it pinned the calling thread), cleared (empty)
// when it is released.
void set_usable_cpus_override(std::vector<int> cpus);
// CPUs as Linux writes a CPU list: "0-3,8", "none" for none (`cpus` ascending).
std::string cpu_list_text(const std::vector<int>& cpus);
// A CPU list as Linux writes it: "0-3,8,10-11" -> {0,1,2,3,8,10,11}; malformed parts skipped.
std::vector<int> parse_cpu_list(const std::string& text);

// One thread of this process as /proc/self/task/<tid>/stat shows it.
struct ThreadSchedInfo {
  pid_t tid = 0;
  std::string name;
  int policy = 0;       // SCHED_OTHER 0, SCHED_FIFO 1, SCHED_RR 2, ...
  int rt_priority = 0;  // 1..99 for SCHED_FIFO / SCHED_RR
};
std::vector<ThreadSchedInfo> process_threads(pid_t pid = 0);  // 0: this process

// Threads of this process under a real-time policy (SCHED_FIFO / SCHED_RR).
std::vector<ThreadSchedInfo> realtime_threads();

}  // namespace rosguard::hw

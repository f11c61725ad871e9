#include "hw/guard/fifo_activity.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/eventfd.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <sstream>

#include "core/error.h"

namespace rosguard::hw {

FifoActivity::FifoActivity(std::string path, std::function<void(const std::string&)> on_bad_line)
    : path_(std::move(path)), on_bad_line_(std::move(on_bad_line)) {}

FifoActivity::~FifoActivity() {
  stop();
}

void FifoActivity::start(const std::vector<std::string>& rt_names, Signal signal) {
  names_ = rt_names;
  signal_ = std::move(signal);
  struct stat st {};
  if (::stat(path_.c_str(), &st) != 0) {
    if (::mkfifo(path_.c_str(), 0620) != 0)
      throw RunError("cannot create the named pipe " + path_ + ": " + errno_text(errno));
  } else if (!S_ISFIFO(st.st_mode)) {
    throw RunError(path_ + " exists and is not a named pipe");
  }
  fd_ = Fd(::open(path_.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC));
  if (!fd_.valid()) throw RunError("cannot open " + path_ + ": " + errno_text(errno));
  stop_fd_ = Fd(::eventfd(0, EFD_CLOEXEC));
  if (!stop_fd_.valid()) throw RunError("eventfd: " + errno_text(errno));
  sigset_t block, old;
  sigemptyset(&block);
  for (int sig : {SIGINT, SIGTERM, SIGHUP})
    sigaddset(&block, sig);
  ::pthread_sigmask(SIG_BLOCK, &block, &old);  // signals go to the main thread
  thread_ = std::thread([this] { main(); });
  ::pthread_sigmask(SIG_SETMASK, &old, nullptr);
}

void FifoActivity::stop() {
  if (!thread_.joinable()) return;
  const std::uint64_t one = 1;
  ssize_t n = ::write(stop_fd_.get(), &one, sizeof one);
  (void)n;
  thread_.join();
}

void FifoActivity::main() {
  std::string pending;
  char buf[512];
  while (true) {
    pollfd fds[2] = {{fd_.get(), POLLIN, 0}, {stop_fd_.get(), POLLIN, 0}};
    if (::poll(fds, 2, -1) < 0) {
      if (errno == EINTR) continue;
      return;
    }
    if (fds[1].revents) return;
    const ssize_t n = ::read(fd_.get(), buf, sizeof buf);
    if (n <= 0) continue;
    pending.append(buf, static_cast<std::size_t>(n));
    for (auto nl = pending.find('\n'); nl != std::string::npos; nl = pending.find('\n')) {
      const std::string line = pending.substr(0, nl);
      pending.erase(0, nl + 1);
      std::istringstream in(line);
      std::string name, state;
      if (!(in >> name)) continue;  // blank line
      in >> state;
      const auto it = std::find(names_.begin(), names_.end(), name);
      const bool on = state == "1" || state == "true";
      const bool off = state == "0" || state == "false";
      if (it == names_.end() || !(on || off)) {
        if (on_bad_line_) on_bad_line_(line);
        continue;
      }
      signal_(
          {static_cast<std::size_t>(it - names_.begin()), on, "the named pipe " + path_, false});
    }
    if (pending.size() > 4096) pending.clear();  // no newline in sight: not our protocol
  }
}

}  // namespace rosguard::hw

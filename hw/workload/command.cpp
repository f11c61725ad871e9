// External commands: fork a supervisor (hw/workload/supervisor.h) that forks the command, which
// waits for the go byte and execs. rosguard counts the command's pid and waits for the supervisor,
// whose wait status is the command's.
#include <fcntl.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <string.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>

#include "core/error.h"
#include "hw/housekeeping.h"
#include "hw/workload/supervisor.h"
#include "hw/workload/workload.h"

namespace rosguard::hw {
namespace {

// Reads one report; false at EOF (every write end closed).
bool read_report(int fd, SupervisorReport& r) {
  ssize_t n;
  do {
    n = ::read(fd, &r, sizeof r);
  } while (n < 0 && errno == EINTR);
  return n == sizeof r;
}

}  // namespace

std::string describe_status(int status) {
  if (WIFEXITED(status)) return "exit " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status))
    return "signal " + std::to_string(WTERMSIG(status)) + " (" + ::strsignal(WTERMSIG(status)) +
           ")";
  return "status " + std::to_string(status);
}

CommandProcess::CommandProcess(const std::vector<std::string>& argv, const ThreadSpec& spec,
                               std::string cwd)
    : argv_(argv), cwd_(std::move(cwd)) {
  if (argv_.empty()) throw RunError("empty command");
  int go[2], rep[2];
  if (::pipe2(go, O_CLOEXEC) != 0) throw RunError("pipe: " + errno_text(errno));
  if (::pipe2(rep, O_CLOEXEC) != 0) {
    ::close(go[0]);
    ::close(go[1]);
    throw RunError("pipe: " + errno_text(errno));
  }
  // Everything the child needs is prepared before fork: only async-signal-safe calls after it.
  std::vector<char*> cargv;
  for (auto& a : argv_)
    cargv.push_back(a.data());
  cargv.push_back(nullptr);
  cpu_set_t set;
  CPU_ZERO(&set);
  if (spec.core >= 0) CPU_SET(spec.core, &set);
  cpu_set_t home;
  CPU_ZERO(&home);
  const std::vector<int> home_cpus = housekeeping_cpus();
  for (int c : home_cpus)
    CPU_SET(c, &home);
  SupervisorSetup setup;
  setup.argv = cargv.data();
  setup.cwd = cwd_.empty() ? nullptr : cwd_.c_str();
  setup.cpus = spec.core >= 0 ? &set : nullptr;
  setup.home = home_cpus.empty() ? nullptr : &home;
  setup.nice = prio::nice_for(spec.priority);
  setup.idle = spec.sched == SchedClass::Idle;
  setup.go_fd = go[0];
  setup.report_fd = rep[1];
  setup.rosguard = ::getpid();

  const pid_t pid = ::fork();
  if (pid < 0) {
    const int e = errno;
    for (int fd : {go[0], go[1], rep[0], rep[1]})
      ::close(fd);
    throw RunError("fork: " + errno_text(e));
  }
  if (pid == 0) {
    ::close(go[1]);
    ::close(rep[0]);
    run_supervisor(setup);
  }
  ::close(go[0]);
  ::close(rep[1]);
  supervisor_ = pid;
  go_ = Fd(go[1]);
  report_ = Fd(rep[0]);
  pidfd_ = Fd(static_cast<int>(::syscall(SYS_pidfd_open, pid, 0)));
  SupervisorReport r;
  if (read_report(report_.get(), r) && r.kind == SupervisorReport::kCommandPid) {
    pid_ = r.value;
    return;
  }
  go_.reset();
  reap();
  if (r.kind == SupervisorReport::kSubreaperFailed)
    throw RunError("cannot contain command '" + argv_[0] +
                   "': prctl(PR_SET_CHILD_SUBREAPER): " + errno_text(r.value));
  if (r.kind == SupervisorReport::kForkFailed)
    throw RunError("cannot run command '" + argv_[0] + "': fork: " + errno_text(r.value));
  throw RunError("cannot run command '" + argv_[0] + "': its supervisor ended with " +
                 describe_status(status_));
}

void CommandProcess::start() {
  const char c = 1;
  ssize_t n;
  do {
    n = ::write(go_.get(), &c, 1);
  } while (n < 0 && errno == EINTR);
  go_.reset();
  SupervisorReport r;
  const bool failed = read_report(report_.get(), r);  // EOF: exec closed the last write end
  report_.reset();
  if (failed) {
    kill();
    if (r.kind == SupervisorReport::kChdirFailed)
      throw RunError("cannot run command '" + argv_[0] + "' in '" + cwd_ +
                     "' (the workload's cwd): " + errno_text(r.value));
    throw RunError("cannot run command '" + argv_[0] + "': " + errno_text(r.value));
  }
}

bool CommandProcess::wait(int stop_fd) {
  if (reaped_) return true;
  while (true) {
    pollfd fds[2] = {{pidfd_.get(), POLLIN, 0}, {stop_fd, POLLIN, 0}};
    const int n = ::poll(fds, stop_fd >= 0 ? 2 : 1, -1);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw RunError("poll on command '" + argv_[0] + "': " + errno_text(errno));
    if (fds[0].revents) {
      reap();
      return true;
    }
    if (stop_fd >= 0 && fds[1].revents) return false;
  }
}

// Asks the supervisor to end the tree and waits for it: it kills and reaps every descendant
// before it exits. A command still waiting for the go byte gives up when go_ closes.
void CommandProcess::kill() {
  if (supervisor_ <= 0 || reaped_) return;
  go_.reset();
  ::kill(supervisor_, SIGTERM);  // not reaped yet: the pid cannot name another process
  reap();
}

void CommandProcess::reap() {
  int st = 0;
  while (::waitpid(supervisor_, &st, 0) < 0 && errno == EINTR) {
  }
  reaped_ = true;
  status_ = st;
}

CommandProcess::~CommandProcess() {
  kill();
}

}  // namespace rosguard::hw

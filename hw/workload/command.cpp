// External commands: fork, configure the child (core, scheduling, process group, parent-death
// signal, default signal mask), wait for the go byte, exec.
#include <fcntl.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>

#include "core/error.h"
#include "hw/workload/workload.h"

namespace rosguard::hw {

std::string describe_status(int status) {
  if (WIFEXITED(status)) return "exit " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status))
    return "signal " + std::to_string(WTERMSIG(status)) + " (" + ::strsignal(WTERMSIG(status)) +
           ")";
  return "status " + std::to_string(status);
}

CommandProcess::CommandProcess(const std::vector<std::string>& argv, const ThreadSpec& spec)
    : argv_(argv) {
  if (argv_.empty()) throw RunError("empty command");
  int go[2], err[2];
  if (::pipe2(go, O_CLOEXEC) != 0) throw RunError("pipe: " + errno_text(errno));
  if (::pipe2(err, O_CLOEXEC) != 0) {
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
  const int nice = prio::nice_for(spec.priority);

  const pid_t pid = ::fork();
  if (pid < 0) {
    const int e = errno;
    for (int fd : {go[0], go[1], err[0], err[1]})
      ::close(fd);
    throw RunError("fork: " + errno_text(e));
  }
  if (pid == 0) {
    ::close(go[1]);
    ::close(err[0]);
    ::setpgid(0, 0);
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    ::signal(SIGINT, SIG_DFL);
    ::signal(SIGTERM, SIG_DFL);
    if (spec.core >= 0) ::sched_setaffinity(0, sizeof set, &set);
    // Never SCHED_FIFO: a program may fork workers that could outlive a killed rosguard, and
    // none of them may be left spinning under a real-time policy. SCHED_OTHER is below every
    // SCHED_FIFO thread of the node, so the THR callback still preempts the whole program.
    ::sched_param zero{};
    ::sched_setscheduler(0, SCHED_OTHER, &zero);
    ::setpriority(PRIO_PROCESS, 0, nice);
    const int devnull = ::open("/dev/null", O_RDWR);
    if (devnull >= 0) {
      ::dup2(devnull, 0);
      ::dup2(devnull, 1);
    }
    char c;
    ssize_t n;
    do {
      n = ::read(go[0], &c, 1);
    } while (n < 0 && errno == EINTR);
    if (n != 1) ::_exit(126);  // the parent gave up
    ::execvp(cargv[0], cargv.data());
    const int e = errno;
    ssize_t w = ::write(err[1], &e, sizeof e);
    (void)w;
    ::_exit(127);
  }
  ::close(go[0]);
  ::close(err[1]);
  pid_ = pid;
  go_ = Fd(go[1]);
  err_ = Fd(err[0]);
  pidfd_ = Fd(static_cast<int>(::syscall(SYS_pidfd_open, pid, 0)));
  ::setpgid(pid, pid);  // also from the parent: no race with kill() before the child ran
}

void CommandProcess::start() {
  const char c = 1;
  ssize_t n;
  do {
    n = ::write(go_.get(), &c, 1);
  } while (n < 0 && errno == EINTR);
  go_.reset();
  int e = 0;
  do {
    n = ::read(err_.get(), &e, sizeof e);
  } while (n < 0 && errno == EINTR);
  err_.reset();
  if (n == sizeof e) {
    kill();
    throw RunError("cannot run command '" + argv_[0] + "': " + errno_text(e));
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

void CommandProcess::kill() {
  if (pid_ <= 0 || reaped_) return;
  reap();  // the group includes the main process: setpgid in both parent and child
}

// Kills what is left of the group (workers the command forked may outlive its main process),
// then collects the main process. In this order: until it is reaped, the main process (alive
// or a zombie) keeps its pid, so -pid_ cannot name another program's recycled process group.
void CommandProcess::reap() {
  ::kill(-pid_, SIGKILL);
  int st = 0;
  while (::waitpid(pid_, &st, 0) < 0 && errno == EINTR) {
  }
  reaped_ = true;
  status_ = st;
}

CommandProcess::~CommandProcess() {
  kill();
}

}  // namespace rosguard::hw

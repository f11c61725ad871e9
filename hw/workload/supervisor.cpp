// The supervisor of an external command (see supervisor.h). It runs in the child of fork() in a
// multi-threaded process and never execs: async-signal-safe system calls only, no allocation.
#include "hw/workload/supervisor.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <initializer_list>

namespace rosguard::hw {
namespace {

void report(int fd, SupervisorReport::Kind kind, int value) {
  const SupervisorReport r{kind, value};
  ssize_t n;
  do {
    n = ::write(fd, &r, sizeof r);
  } while (n < 0 && errno == EINTR);
}

void set_default(int sig) {
  struct sigaction dfl {};
  dfl.sa_handler = SIG_DFL;
  ::sigaction(sig, &dfl, nullptr);
}

// Writes the decimal digits of v (>= 0) at p; returns the end.
char* put_number(char* p, long v) {
  char digits[24];
  int n = 0;
  do {
    digits[n++] = static_cast<char>('0' + v % 10);
    v /= 10;
  } while (v > 0);
  while (n > 0)
    *p++ = digits[--n];
  return p;
}

char* put_text(char* p, const char* s) {
  while (*s)
    *p++ = *s++;
  return p;
}

// The numbers in a file of pids separated by blanks (/proc/.../children): f(pid) for each.
template <class F>
void for_each_number_in(int fd, F&& f) {
  char buf[512];
  long cur = 0;
  bool in_number = false;
  ssize_t n;
  while ((n = ::read(fd, buf, sizeof buf)) > 0 || (n < 0 && errno == EINTR))
    for (ssize_t i = 0; i < n; ++i) {
      if (buf[i] >= '0' && buf[i] <= '9') {
        cur = cur * 10 + (buf[i] - '0');
        in_number = true;
      } else if (in_number) {
        f(static_cast<pid_t>(cur));
        cur = 0;
        in_number = false;
      }
    }
  if (in_number) f(static_cast<pid_t>(cur));
}

// The parent pid in /proc/<pid>/stat ("pid (comm) state ppid ..."; comm may hold ')' and blanks,
// so the fields are counted from the last ')'), or -1.
pid_t parent_of(const char* pid_text) {
  char path[64];
  *put_text(put_text(put_text(path, "/proc/"), pid_text), "/stat") = '\0';
  const int fd = ::open(path, O_RDONLY | O_CLOEXEC);
  if (fd < 0) return -1;
  char buf[512];
  const ssize_t n = ::read(fd, buf, sizeof buf - 1);
  ::close(fd);
  if (n <= 0) return -1;
  const char* close_paren = nullptr;
  for (ssize_t i = 0; i < n; ++i)
    if (buf[i] == ')') close_paren = buf + i;
  if (!close_paren || close_paren + 4 >= buf + n) return -1;
  long ppid = 0;
  for (const char* p = close_paren + 4; p < buf + n && *p >= '0' && *p <= '9'; ++p)
    ppid = ppid * 10 + (*p - '0');
  return static_cast<pid_t>(ppid);
}

// Every process on the host whose parent is `self`, read from each /proc/<pid>/stat: for kernels
// without CONFIG_PROC_CHILDREN. Slower (one file per process), as complete.
template <class F>
void scan_proc_for_children(pid_t self, F&& f) {
  const int dir = ::open("/proc", O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir < 0) return;
  alignas(8) char buf[4096];
  long n;
  while ((n = ::syscall(SYS_getdents64, dir, buf, sizeof buf)) > 0)
    for (long off = 0; off < n;) {
      // struct linux_dirent64: d_ino (8), d_off (8), d_reclen (2), d_type (1), d_name.
      unsigned short reclen;
      __builtin_memcpy(&reclen, buf + off + 16, sizeof reclen);
      const char* name = buf + off + 19;
      off += reclen;
      long pid = 0;
      const char* p = name;
      for (; *p >= '0' && *p <= '9'; ++p)
        pid = pid * 10 + (*p - '0');
      if (p == name || *p != '\0') continue;  // not a process directory
      if (parent_of(name) == self) f(static_cast<pid_t>(pid));
    }
  ::close(dir);
}

// f(pid) for each child of this single-threaded process (its children hang off its one task).
template <class F>
void for_each_child(pid_t self, F&& f) {
  char path[64];
  char* p = put_number(put_text(path, "/proc/self/task/"), self);
  *put_text(p, "/children") = '\0';
  const int fd = ::open(path, O_RDONLY | O_CLOEXEC);
  if (fd < 0) return scan_proc_for_children(self, f);
  for_each_number_in(fd, f);
  ::close(fd);
}

// SIGKILLs every descendant and reaps each one; returns the command's wait status. One kill takes
// the command's process group; a descendant in another group or session is re-parented to us
// (its subreaper) before its parent can be reaped, so killing every child before each wait
// reaches it on a later turn, and the loop ends when no child is left.
int kill_tree(pid_t self, pid_t command) {
  ::kill(-command, SIGKILL);  // not reaped yet: -command still names the command's own group
  int command_status = 0;
  while (true) {
    for_each_child(self, [](pid_t child) { ::kill(child, SIGKILL); });
    int status = 0;
    const pid_t done = ::waitpid(-1, &status, __WALL);
    if (done < 0 && errno == EINTR) continue;
    if (done < 0) return command_status;  // ECHILD: the tree is gone
    if (done == command) command_status = status;
  }
}

// Ends this process as the command ended: the same exit code, or the same signal.
[[noreturn]] void exit_like(int status) {
  if (WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    const rlimit no_core{0, 0};
    ::setrlimit(RLIMIT_CORE, &no_core);  // a core dump of the supervisor would say nothing
    set_default(sig);
    sigset_t one;
    sigemptyset(&one);
    sigaddset(&one, sig);
    ::sigprocmask(SIG_UNBLOCK, &one, nullptr);
    ::kill(::getpid(), sig);
    ::_exit(128 + sig);  // a signal whose default is not to terminate
  }
  ::_exit(WIFEXITED(status) ? WEXITSTATUS(status) : 126);
}

// Sleeps until the command exits or a stop is asked for (rosguard's SIGTERM, or the parent-death
// signal), reaping orphans of the tree as they end meanwhile.
[[noreturn]] void supervise(pid_t self, pid_t command) {
  sigset_t wake;
  sigemptyset(&wake);
  for (int sig : {SIGCHLD, SIGTERM, SIGINT, SIGHUP, SIGQUIT})
    sigaddset(&wake, sig);
  while (true) {
    const int sig = ::sigwaitinfo(&wake, nullptr);
    if (sig > 0 && sig != SIGCHLD) exit_like(kill_tree(self, command));
    while (true) {
      siginfo_t info{};
      // Peek first: the command must stay unreaped until kill_tree() has killed its group.
      if (::waitid(P_ALL, 0, &info, WEXITED | WNOHANG | WNOWAIT | __WALL) != 0 || info.si_pid == 0)
        break;
      if (info.si_pid == command) exit_like(kill_tree(self, command));
      ::waitpid(info.si_pid, nullptr, __WALL);
    }
  }
}

void close_all_fds() {
#ifdef SYS_close_range
  if (::syscall(SYS_close_range, 0U, ~0U, 0U) == 0) return;
#endif
  rlimit r{};
  const rlim_t limit = ::getrlimit(RLIMIT_NOFILE, &r) == 0 ? r.rlim_cur : 1024;
  for (rlim_t fd = 0; fd < limit && fd < (1u << 20); ++fd)
    ::close(static_cast<int>(fd));
}

// The command's side of the fork: its own process group, killed if the supervisor dies, default
// signals, stdin and stdout on /dev/null; waits for the go byte, then execs.
[[noreturn]] void exec_command(const SupervisorSetup& s, pid_t supervisor) {
  ::setpgid(0, 0);
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (::getppid() != supervisor) ::_exit(126);
  set_default(SIGINT);
  set_default(SIGTERM);
  sigset_t none;
  sigemptyset(&none);
  ::sigprocmask(SIG_SETMASK, &none, nullptr);
  const int devnull = ::open("/dev/null", O_RDWR | O_CLOEXEC);
  if (devnull >= 0) {
    ::dup2(devnull, 0);
    ::dup2(devnull, 1);
  }
  char c;
  ssize_t n;
  do {
    n = ::read(s.go_fd, &c, 1);
  } while (n < 0 && errno == EINTR);
  if (n != 1) ::_exit(126);  // rosguard gave up
  if (s.cwd && ::chdir(s.cwd) != 0) {
    report(s.report_fd, SupervisorReport::kChdirFailed, errno);
    ::_exit(127);
  }
  ::execvp(s.argv[0], s.argv);
  report(s.report_fd, SupervisorReport::kExecFailed, errno);
  ::_exit(127);
}

}  // namespace

void run_supervisor(const SupervisorSetup& s) {
  ::setpgid(0, 0);  // out of rosguard's group: a kill of that group must not end us first
  sigset_t all;
  sigfillset(&all);
  ::sigprocmask(SIG_SETMASK, &all, nullptr);  // signals are taken with sigwaitinfo()
  set_default(SIGCHLD);  // ignored, SIGCHLD would reap the command and lose its status
  if (s.cpus) ::sched_setaffinity(0, sizeof *s.cpus, s.cpus);
  // Never SCHED_FIFO: a program may fork workers, and none of them may spin under a real-time
  // policy. SCHED_OTHER is below every SCHED_FIFO thread of the node, so the THR callback still
  // preempts the whole program. The command inherits all of this.
  const sched_param zero{};
  if (s.idle) {
    ::sched_setscheduler(0, SCHED_IDLE, &zero);
  } else {
    ::sched_setscheduler(0, SCHED_OTHER, &zero);
    ::setpriority(PRIO_PROCESS, 0, s.nice);
  }
  if (::prctl(PR_SET_CHILD_SUBREAPER, 1) != 0) {
    report(s.report_fd, SupervisorReport::kSubreaperFailed, errno);
    ::_exit(126);
  }
  ::prctl(PR_SET_PDEATHSIG, SIGTERM);
  if (::getppid() != s.rosguard) ::_exit(126);  // rosguard died before the signal was armed
  const pid_t self = ::getpid();
  const pid_t command = ::fork();
  if (command < 0) {
    report(s.report_fd, SupervisorReport::kForkFailed, errno);
    ::_exit(126);
  }
  if (command == 0) exec_command(s, self);
  ::setpgid(command, command);  // also from here: no race with kill_tree()'s group kill
  if (s.home) ::sched_setaffinity(0, sizeof *s.home, s.home);  // the command keeps `cpus`
  report(s.report_fd, SupervisorReport::kCommandPid, command);
  close_all_fds();  // rosguard's pipes and files: none may be held open by us
  supervise(self, command);
}

}  // namespace rosguard::hw

// The supervisor of an external command: a fork of rosguard that stands between rosguard and the
// command, so that nothing the command starts outlives the run, however the run ends.
//
// Contract:
// - run_supervisor() is called in the child of fork() (CommandProcess's constructor) of a
//   multi-threaded process and never returns: it and everything it calls use async-signal-safe
//   system calls only (no allocation, no locks, no exceptions).
// - The supervisor is a child subreaper (PR_SET_CHILD_SUBREAPER): every descendant of the
//   command, even one that leaves its process group or session (setsid, a daemon's double
//   fork), is re-parented to it, never to init. It forks the command, reports the command's pid,
//   closes every inherited descriptor and sleeps in sigwaitinfo().
// - It ends the whole tree (SIGKILL to every descendant, each one reaped) when the command exits,
//   when asked to stop (SIGTERM, SIGINT, SIGHUP or SIGQUIT), and when rosguard's forking thread
//   dies, SIGKILL included (parent-death signal SIGTERM). It then exits as the command did (same
//   exit code, or killed by the same signal), so its wait status stands for the command's.
// - The command itself is forked at once and waits for the go byte before exec: its pid is the
//   one to count (perf counters opened on it before exec follow it and, with inherit, its
//   children), exactly as when rosguard forked it directly.
#pragma once

#include <sched.h>
#include <sys/types.h>

#include <cstdint>

namespace rosguard::hw {

// A message on the report pipe (supervisor or command -> rosguard): 8 bytes, below PIPE_BUF, so
// each write is atomic.
struct SupervisorReport {
  enum Kind : std::int32_t {
    kCommandPid = 1,       // value: the command's pid (the supervisor is ready)
    kSubreaperFailed = 2,  // value: errno of prctl(PR_SET_CHILD_SUBREAPER)
    kForkFailed = 3,       // value: errno of fork()
    kExecFailed = 4,       // value: errno of execvp() (written by the command's child)
    kChdirFailed = 5,      // value: errno of chdir() into the command's directory (ditto)
  };
  std::int32_t kind = 0;
  std::int32_t value = 0;
};

// Everything the supervisor needs, prepared before fork().
struct SupervisorSetup {
  char* const* argv = nullptr;      // the command, null-terminated
  const char* cwd = nullptr;        // the directory the command starts in; null: inherited
  const cpu_set_t* cpus = nullptr;  // affinity of the supervisor and the command; null: inherit
  // Where the supervisor moves itself once the command is forked (rosguard's housekeeping CPUs,
  // hw/housekeeping.h: off the measured core); null: it stays with the command.
  const cpu_set_t* home = nullptr;
  int nice = 0;        // SCHED_OTHER nice value of both
  bool idle = false;   // SCHED_IDLE instead (the idle throttle's work)
  int go_fd = -1;      // read end: one byte lets the command exec, EOF makes it give up
  int report_fd = -1;  // write end of the report pipe (close-on-exec)
  pid_t rosguard = 0;  // getpid() before fork: the parent whose death ends the supervision
};

[[noreturn]] void run_supervisor(const SupervisorSetup& setup);

}  // namespace rosguard::hw

#include "hw/guard/core_tasks.h"

#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <utility>

#include "core/error.h"
#include "hw/common/clock.h"
#include "hw/common/sys.h"
#include "hw/pmc_source/perf.h"

namespace rosguard::hw {
namespace {

namespace fs = std::filesystem;

constexpr unsigned long kPfKthread = 0x00200000;  // task flags in /proc/<tid>/stat (field 9)

bool all_digits(const std::string& s) {
  return !s.empty() && s.find_first_not_of("0123456789") == std::string::npos;
}

// comm and flags of a thread from /proc/<pid>/task/<tid>/stat; false when it is gone, or
// exiting (a zombie that no parent has reaped yet is nothing to regulate).
bool read_stat(const std::string& path, std::string& comm, unsigned long& flags) {
  std::ifstream in(path);
  std::string text;
  if (!std::getline(in, text)) return false;
  const auto open = text.find('('), close = text.rfind(')');
  if (open == std::string::npos || close == std::string::npos) return false;
  comm = text.substr(open + 1, close - open - 1);
  std::istringstream rest(text.substr(close + 2));
  std::string field;
  // state ppid pgrp session tty_nr tpgid flags
  for (int i = 0; i < 7 && rest >> field; ++i) {
    if (i == 0 && (field == "Z" || field == "X")) return false;
    if (i == 6) flags = std::stoul(field);
  }
  return true;
}

std::string cgroup_of(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/cgroup");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("0::", 0) == 0) return line.substr(3);
  return {};
}

std::string cgroup2_mount_point() {
  std::ifstream in("/proc/self/mountinfo");
  std::string line;
  while (std::getline(in, line)) {
    const auto dash = line.find(" - ");
    if (dash == std::string::npos || line.compare(dash + 3, 8, "cgroup2 ") != 0) continue;
    std::istringstream head(line.substr(0, dash));
    std::string id, parent, devno, root, mount;
    head >> id >> parent >> devno >> root >> mount;
    return mount;
  }
  return {};
}

bool write_text(const std::string& path, const std::string& text) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool ok = ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size());
  ::close(fd);
  return ok;
}

// Start time of a thread (clock ticks since boot, /proc/<tid>/stat field 22); 0 when it is gone.
unsigned long long start_time_of(pid_t tid) {
  std::ifstream in("/proc/" + std::to_string(tid) + "/stat");
  std::string text;
  if (!std::getline(in, text)) return 0;
  const auto close = text.rfind(')');
  if (close == std::string::npos) return 0;
  std::istringstream rest(text.substr(close + 2));
  std::string field;
  for (int i = 3; i <= 22 && rest >> field; ++i)
    if (i == 22) return std::stoull(field);
  return 0;
}

bool is_rosguard_cgroup(const std::string& path) {
  const auto slash = path.rfind('/');
  return path.compare(slash == std::string::npos ? 0 : slash + 1, 9, "rosguard-") == 0;
}

const char* policy_name(int policy) {
  switch (policy) {
    case SCHED_OTHER:
      return "SCHED_OTHER";
    case SCHED_BATCH:
      return "SCHED_BATCH";
    case SCHED_IDLE:
      return "SCHED_IDLE";
    case SCHED_FIFO:
      return "SCHED_FIFO";
    case SCHED_RR:
      return "SCHED_RR";
  }
  return "another policy";
}

// CPU time of a thread in ns (first field of /proc/<tid>/schedstat), or -1 when it is gone.
long long thread_cpu_ns_of(pid_t tid) {
  char path[64];
  std::snprintf(path, sizeof path, "/proc/%d/schedstat", static_cast<int>(tid));
  const int fd = ::open(path, O_RDONLY | O_CLOEXEC);
  if (fd < 0) return -1;
  char buf[96];
  const ssize_t n = ::read(fd, buf, sizeof buf - 1);
  ::close(fd);
  if (n <= 0) return -1;
  buf[n] = '\0';
  return std::strtoll(buf, nullptr, 10);
}

// Sets a thread's affinity to a CPU list ("0-3,6"); false when it is gone or refused.
bool set_affinity(pid_t tid, const std::string& list) {
  cpu_set_t set;
  CPU_ZERO(&set);
  for (int c : parse_cpu_list(list))
    if (c >= 0 && c < CPU_SETSIZE) CPU_SET(c, &set);
  return ::sched_setaffinity(tid, sizeof set, &set) == 0;
}

const NamedEvent& task_clock_event() {
  static const NamedEvent e{"task_clock", *software_event("task_clock")};
  return e;
}

}  // namespace

std::optional<std::string> task_clock_unavailable() {
  try {
    open_perf_group({task_clock_event()}, PmcTarget{});
    return std::nullopt;
  } catch (const RunError& e) {
    return std::string(e.what());
  }
}

long long CpuTimeGroup::thread_ns(pid_t tid) {
  if (!task_clock_) return thread_cpu_ns_of(tid);
  auto it = clocks_.find(tid);
  if (it == clocks_.end()) {
    PmcTarget t;
    t.pid = tid;
    try {
      it = clocks_.emplace(tid, open_perf_group({task_clock_event()}, t)).first;
    } catch (const RunError&) {
      return -1;  // gone before it could be counted
    }
  }
  CounterValue v;
  it->second->read(std::span(&v, 1));
  return static_cast<long long>(v.value);
}

void CpuTimeGroup::publish(std::vector<pid_t> tids) {
  std::lock_guard lock(mutex_);
  published_ = std::move(tids);
}

void CpuTimeGroup::read(std::span<CounterValue> out) {
  if (out.empty()) return;
  const TimeNs now = now_ns();
  if (first_ < 0) first_ = now;
  if (std::unique_lock lock(mutex_, std::try_to_lock); lock.owns_lock()) tids_ = published_;
  std::uint64_t total = ended_ns_;
  std::set<pid_t> current(tids_.begin(), tids_.end());
  // Threads that left the list (ended or no longer pinned) keep what they ran while pinned.
  for (auto it = last_.begin(); it != last_.end();) {
    if (!current.count(it->first)) {
      ended_ns_ += it->second;
      total += it->second;
      base_.erase(it->first);
      clocks_.erase(it->first);
      it = last_.erase(it);
    } else {
      ++it;
    }
  }
  for (pid_t tid : tids_) {
    const long long ns = thread_ns(tid);
    auto it = last_.find(tid);
    if (ns < 0) continue;  // gone: dropped at the next list
    // Counted from when it was first seen pinned (its earlier CPU time is not this core's).
    if (it == last_.end()) {
      it = last_.emplace(tid, 0).first;
      base_[tid] = static_cast<std::uint64_t>(ns);
    }
    it->second = static_cast<std::uint64_t>(ns) - base_[tid];
    total += it->second;
  }
  out[0] = {total, static_cast<std::uint64_t>(now - first_),
            static_cast<std::uint64_t>(now - first_)};
  for (std::size_t i = 1; i < out.size(); ++i)
    out[i] = {};
}

CoreTasks::CoreTasks(ThrottleKind kind, std::vector<Core> cores, std::string record,
                     std::vector<std::string> pin)
    : kind_(kind),
      cores_(std::move(cores)),
      record_(std::move(record)),
      pin_(std::move(pin)),
      cgroup_mount_(cgroup2_mount_point()) {
  save();  // the cgroups exist already
}

// The record: a header line with the guard's pid, then one line per change made.
void CoreTasks::save() const {
  if (record_.empty()) return;
  std::ostringstream out;
  out << "rosguard-guard-record 1 " << ::getpid() << "\n";
  for (const auto& c : cores_)
    if (c.cgroup) out << "cgroup " << c.cgroup->path() << "\n";
  for (const auto& [tid, t] : tasks_)
    if (t.idle_applied)
      out << "idle " << tid << " " << t.start_time << " " << t.policy << " " << t.priority << " "
          << t.nice << "\n";
  for (const auto& [pid, m] : moved_)
    out << "moved " << pid << " " << m.start_time << " " << m.cgroup << "\n";
  for (const auto& [tid, p] : pinned_)
    out << "pinned " << tid << " " << p.start_time << " " << p.cpus << "\n";
  const std::string tmp = record_ + ".tmp";
  {
    std::ofstream f(tmp, std::ios::trunc);
    f << out.str();
    if (!f.flush()) throw RunError("cannot write " + tmp + ": " + errno_text(errno));
  }
  if (::rename(tmp.c_str(), record_.c_str()) != 0)
    throw RunError("cannot rename " + tmp + " to " + record_ + ": " + errno_text(errno));
}

std::vector<std::string> CoreTasks::repair(const std::string& path) {
  std::vector<std::string> done;
  std::ifstream in(path);
  if (!in) return done;
  std::string line, magic;
  long guard_pid = 0;
  int version = 0;
  if (!std::getline(in, line) || !(std::istringstream(line) >> magic >> version >> guard_pid) ||
      magic != "rosguard-guard-record") {
    done.push_back("ignored " + path + ": not a guard record");
    return done;
  }
  if (guard_pid != ::getpid() && ::kill(static_cast<pid_t>(guard_pid), 0) == 0) {
    std::ifstream comm("/proc/" + std::to_string(guard_pid) + "/comm");
    std::string name;
    std::getline(comm, name);
    if (name == "rosguard")
      throw RunError("another rosguard guard runs with this name (pid " +
                     std::to_string(guard_pid) + ", its record " + path +
                     "): stop it first, or give this one another name");
  }
  const std::string mount = cgroup2_mount_point();
  std::vector<std::string> cgroups;
  struct Idle {
    pid_t tid;
    unsigned long long start;
    int policy, priority, nice;
  };
  std::vector<Idle> idle;
  std::vector<std::pair<pid_t, std::pair<unsigned long long, std::string>>> moved;
  std::vector<std::pair<pid_t, Pinned>> pinned;
  while (std::getline(in, line)) {
    std::istringstream l(line);
    std::string kind;
    l >> kind;
    if (kind == "cgroup") {
      std::string p;
      std::getline(l >> std::ws, p);
      cgroups.push_back(p);
    } else if (kind == "idle") {
      Idle i{};
      if (l >> i.tid >> i.start >> i.policy >> i.priority >> i.nice) idle.push_back(i);
    } else if (kind == "pinned") {
      pid_t tid = 0;
      Pinned pin;
      if (l >> tid >> pin.start_time >> pin.cpus) pinned.emplace_back(tid, pin);
    } else if (kind == "moved") {
      pid_t pid = 0;
      unsigned long long start = 0;
      std::string cg;
      if (l >> pid >> start) {
        std::getline(l >> std::ws, cg);
        moved.push_back({pid, {start, cg}});
      }
    }
  }
  const std::string who = "guard pid " + std::to_string(guard_pid);
  // Thaw first: a process leaves a frozen cgroup thawed.
  for (const auto& cg : cgroups)
    if (write_text(cg + "/cgroup.freeze", "0")) done.push_back("thawed " + cg + " (" + who + ")");
  for (const auto& [pid, m] : moved) {
    if (start_time_of(pid) != m.first) continue;  // gone, or another process with its pid
    const std::string to = is_rosguard_cgroup(m.second) || m.second.empty() ? "/" : m.second;
    if (!mount.empty() &&
        write_text(mount + (to == "/" ? "" : to) + "/cgroup.procs", std::to_string(pid)))
      done.push_back("process " + std::to_string(pid) + " back in cgroup " + to);
  }
  for (const auto& i : idle) {
    if (start_time_of(i.tid) != i.start || ::sched_getscheduler(i.tid) != SCHED_IDLE) continue;
    const sched_param sp{i.priority};
    if (::sched_setscheduler(i.tid, i.policy, &sp) == 0) {
      ::setpriority(PRIO_PROCESS, static_cast<id_t>(i.tid), i.nice);
      done.push_back("thread " + std::to_string(i.tid) + " back to " + policy_name(i.policy) +
                     " (nice " + std::to_string(i.nice) + ") from SCHED_IDLE");
    }
  }
  for (const auto& [tid, p] : pinned) {
    if (start_time_of(tid) != p.start_time) continue;
    if (set_affinity(tid, p.cpus))
      done.push_back("thread " + std::to_string(tid) + " back to CPUs " + p.cpus);
  }
  // The cgroups go; what is still in one (a process this record did not name) goes to its parent.
  for (const auto& cg : cgroups) {
    std::ifstream procs(cg + "/cgroup.procs");
    if (!procs) continue;
    const std::string parent = cg.substr(0, cg.rfind('/'));
    long p;
    while (procs >> p)
      write_text(parent + "/cgroup.procs", std::to_string(p));
    for (int k = 0; k < 100 && ::rmdir(cg.c_str()) != 0 && errno == EBUSY; ++k)
      ::usleep(1000);
    done.push_back(::access(cg.c_str(), F_OK) == 0
                       ? "could not remove cgroup " + cg + ": " + errno_text(errno)
                       : "removed cgroup " + cg);
  }
  ::unlink(path.c_str());
  return done;
}

CoreTasks::~CoreTasks() {
  restore();
}

std::size_t CoreTasks::count(int core) const {
  return static_cast<std::size_t>(std::count_if(
      tasks_.begin(), tasks_.end(), [&](const auto& t) { return t.second.core == core; }));
}

std::vector<std::string> CoreTasks::take_unregulated() {
  // Forget the processes that ended (their pids may come back as others).
  for (auto it = unregulated_.begin(); it != unregulated_.end();)
    it = ::kill(*it, 0) != 0 && errno == ESRCH ? unregulated_.erase(it) : std::next(it);
  return std::exchange(unregulated_new_, {});
}

int CoreTasks::pin(pid_t pid, pid_t tid, const cpu_set_t& set, std::string& why) {
  if (pin_.empty()) return -1;
  std::string name;
  std::getline(std::ifstream("/proc/" + std::to_string(pid) + "/comm"), name);
  if (std::find(pin_.begin(), pin_.end(), name) == pin_.end()) return -1;
  std::vector<int> allowed;
  for (const auto& c : cores_)
    if (CPU_ISSET(c.core, &set)) allowed.push_back(c.core);
  std::vector<int> cpus;
  for (int c = 0; c < CPU_SETSIZE; ++c)
    if (CPU_ISSET(c, &set)) cpus.push_back(c);
  if (allowed.empty()) {
    if (not_pinned_.insert(pid).second)
      why = "pin_processes: left alone, its CPUs (" + cpu_list_text(cpus) + ") include no nRT core";
    return -1;
  }
  const int core = allowed[next_core_[pid]++ % allowed.size()];
  pinned_[tid] = {start_time_of(tid), cpu_list_text(cpus)};
  save();  // recorded before it is changed
  if (!set_affinity(tid, std::to_string(core))) {
    why = "pin_processes: cannot pin it to CPU " + std::to_string(core) + " (" + errno_text(errno) +
          "): left alone";
    pinned_.erase(tid);
    return -1;
  }
  why = "pinned to CPU " + std::to_string(core) + " (pin_processes; its CPUs were " +
        cpu_list_text(cpus) + ", given back when the guard stops)";
  return core;
}

std::vector<CoreTasks::Change> CoreTasks::rescan() {
  std::vector<Change> changes;
  const pid_t self = ::getpid();
  std::set<pid_t> seen;
  std::map<int, std::vector<pid_t>> per_core;
  std::set<pid_t> glimpsed_now;
  std::error_code ec;
  for (const auto& p : fs::directory_iterator("/proc", ec)) {
    const std::string pname = p.path().filename().string();
    if (!all_digits(pname)) continue;
    const pid_t pid = static_cast<pid_t>(std::stol(pname));
    if (pid == self) continue;
    std::error_code ec2;
    for (const auto& t : fs::directory_iterator(p.path() / "task", ec2)) {
      const std::string tname = t.path().filename().string();
      if (!all_digits(tname)) continue;
      const pid_t tid = static_cast<pid_t>(std::stol(tname));
      cpu_set_t set;
      CPU_ZERO(&set);
      if (::sched_getaffinity(tid, sizeof set, &set) != 0) continue;
      std::string comm;
      unsigned long flags = 0;
      std::string pin_note;
      if (CPU_COUNT(&set) != 1) {
        // Known already (said not regulated, or a process of pin_ with no nRT core): no more
        // file reads for it at every rescan.
        if (unregulated_.count(pid) || not_pinned_.count(pid)) continue;
        if (!std::any_of(cores_.begin(), cores_.end(),
                         [&](const Core& c) { return CPU_ISSET(c.core, &set); }) ||
            !read_stat((t.path() / "stat").string(), comm, flags) || (flags & kPfKthread))
          continue;
        const int to = pin(pid, tid, set, pin_note);
        if (to < 0) {
          if (!pin_note.empty()) changes.push_back({-1, pid, tid, comm, false, pin_note});
          // May run on an nRT core, not regulated: said once per process, at the first rescan
          // or once it was seen by two (a short-lived command is not worth a line).
          if (pin_note.empty() && (scans_ == 0 || glimpsed_.count(pid))) {
            unregulated_.insert(pid);
            unregulated_new_.push_back(comm + " " + std::to_string(pid));
          }
          glimpsed_now.insert(pid);
          continue;
        }
        CPU_ZERO(&set);
        CPU_SET(to, &set);
      }
      const auto core = std::find_if(cores_.begin(), cores_.end(),
                                     [&](const Core& c) { return CPU_ISSET(c.core, &set); });
      if (core == cores_.end()) continue;
      if (!read_stat((t.path() / "stat").string(), comm, flags) || (flags & kPfKthread)) continue;
      seen.insert(tid);
      auto known = tasks_.find(tid);
      if (known != tasks_.end()) {
        if (known->second.policy != SCHED_FIFO && known->second.policy != SCHED_RR)
          per_core[core->core].push_back(tid);
        continue;
      }
      Task task;
      task.core = core->core;
      task.pid = pid;
      task.policy = ::sched_getscheduler(tid);
      sched_param sp{};
      ::sched_getparam(tid, &sp);
      task.priority = sp.sched_priority;
      errno = 0;
      task.nice = ::getpriority(PRIO_PROCESS, static_cast<id_t>(tid));
      task.start_time = start_time_of(tid);
      Change ch{core->core, pid, tid, comm, true, pin_note};
      const auto with = [&](const std::string& note) {
        return pin_note.empty() ? note : pin_note + "; " + note;
      };
      if (task.policy == SCHED_FIFO || task.policy == SCHED_RR) {
        ch.note = with("runs under a real-time policy: left alone, not counted");
      } else {
        per_core[core->core].push_back(tid);
        if (kind_ == ThrottleKind::Idle && task.policy != SCHED_IDLE) {
          // Recorded before it is changed: a guard killed in between leaves a record to repair.
          task.idle_applied = true;
          tasks_.emplace(tid, task);
          save();
          const sched_param zero{};
          if (::sched_setscheduler(tid, SCHED_IDLE, &zero) == 0) {
            ch.note = with("moved to SCHED_IDLE");
          } else {
            ch.note =
                with("SCHED_IDLE refused (" + errno_text(errno) + "): the throttle cannot hold it");
            tasks_[tid].idle_applied = false;
          }
        } else if (kind_ == ThrottleKind::Freezer && core->cgroup && !moved_.count(pid)) {
          const std::string before = cgroup_of(pid);
          moved_[pid] = {before, start_time_of(pid)};
          save();
          try {
            core->cgroup->add(pid);
            ch.note = with("process moved into " + core->cgroup->path());
          } catch (const RunError& e) {
            moved_.erase(pid);
            ch.note = with(std::string("not frozen: ") + e.what());
          }
        }
      }
      tasks_.emplace(tid, task);  // (no-op when recorded above)
      changes.push_back(std::move(ch));
    }
  }
  glimpsed_ = std::move(glimpsed_now);
  ++scans_;
  for (auto it = tasks_.begin(); it != tasks_.end();) {
    if (seen.count(it->first)) {
      ++it;
      continue;
    }
    pinned_.erase(it->first);
    // Ended, or no longer pinned to an nRT core: give it back its scheduling.
    Change ch{it->second.core, it->second.pid, it->first, "", false, ""};
    if (it->second.idle_applied) {
      const sched_param sp{it->second.priority};
      if (::sched_setscheduler(it->first, it->second.policy, &sp) == 0) {
        ::setpriority(PRIO_PROCESS, static_cast<id_t>(it->first), it->second.nice);
        ch.note = "scheduling restored (left the core)";
      }
    }
    changes.push_back(std::move(ch));
    it = tasks_.erase(it);
  }
  for (auto& c : cores_)
    if (c.cputime) c.cputime->publish(per_core[c.core]);
  if (!changes.empty()) save();
  return changes;
}

void CoreTasks::restore() {
  for (const auto& [tid, t] : tasks_)
    if (t.idle_applied) {
      const sched_param sp{t.priority};
      if (::sched_setscheduler(tid, t.policy, &sp) == 0)
        ::setpriority(PRIO_PROCESS, static_cast<id_t>(tid), t.nice);
    }
  tasks_.clear();
  for (const auto& [tid, p] : pinned_)
    if (start_time_of(tid) == p.start_time) set_affinity(tid, p.cpus);
  pinned_.clear();
  if (!cgroup_mount_.empty())
    for (const auto& [pid, m] : moved_) {
      // Never back into a guard's cgroup (one a killed guard left): the cgroup root instead.
      const std::string to = is_rosguard_cgroup(m.cgroup) || m.cgroup.empty() ? "/" : m.cgroup;
      write_text(cgroup_mount_ + (to == "/" ? "" : to) + "/cgroup.procs", std::to_string(pid));
    }
  moved_.clear();
  // Everything undone; the cgroups themselves go with the nodes (FreezerCgroup).
  if (!record_.empty()) ::unlink(record_.c_str());
}

}  // namespace rosguard::hw

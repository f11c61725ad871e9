#include "hw/common/sys.h"

#include <dirent.h>
#include <sched.h>
#include <string.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <fstream>
#include <mutex>
#include <sstream>

namespace rosguard::hw {

std::string errno_text(int err) {
  const char* name = ::strerrorname_np(err);
  return std::string(name ? name : "errno " + std::to_string(err)) + " (" + ::strerror(err) + ")";
}

void Fd::reset() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

pid_t current_tid() {
  return static_cast<pid_t>(::syscall(SYS_gettid));
}

namespace {
std::mutex g_override_mutex;
std::vector<int> g_override;
}  // namespace

void set_usable_cpus_override(std::vector<int> cpus) {
  const std::lock_guard lock(g_override_mutex);
  g_override = std::move(cpus);
}

std::string cpu_list_text(const std::vector<int>& cpus) {
  std::string s;
  for (std::size_t i = 0; i < cpus.size();) {
    std::size_t j = i;
    while (j + 1 < cpus.size() && cpus[j + 1] == cpus[j] + 1)
      ++j;
    s += (s.empty() ? "" : ",") + std::to_string(cpus[i]) +
         (j > i ? "-" + std::to_string(cpus[j]) : "");
    i = j + 1;
  }
  return s.empty() ? "none" : s;
}

std::vector<int> parse_cpu_list(const std::string& text) {
  std::vector<int> out;
  std::stringstream ss(text);
  for (std::string part; std::getline(ss, part, ',');) {
    if (part.empty()) continue;
    const auto dash = part.find('-');
    try {
      const int a = std::stoi(part.substr(0, dash));
      const int b = dash == std::string::npos ? a : std::stoi(part.substr(dash + 1));
      for (int c = a; c <= b && c - a < 65536; ++c)
        out.push_back(c);
    } catch (const std::exception&) {
    }
  }
  return out;
}

std::vector<int> usable_cpus() {
  {
    const std::lock_guard lock(g_override_mutex);
    if (!g_override.empty()) return g_override;
  }
  cpu_set_t set;
  CPU_ZERO(&set);
  std::vector<int> out;
  if (::sched_getaffinity(0, sizeof set, &set) != 0) return out;
  const long online = ::sysconf(_SC_NPROCESSORS_ONLN);
  const long conf = std::max(online, ::sysconf(_SC_NPROCESSORS_CONF));
  for (int c = 0; c < conf && c < CPU_SETSIZE; ++c) {
    if (!CPU_ISSET(c, &set)) continue;
    std::ifstream f("/sys/devices/system/cpu/cpu" + std::to_string(c) + "/online");
    int on = 1;
    if (f) f >> on;  // cpu0 often has no "online" file: it is always online
    if (on) out.push_back(c);
  }
  return out;
}

std::vector<ThreadSchedInfo> process_threads(pid_t pid) {
  const std::string base = pid == 0 ? "/proc/self/task" : "/proc/" + std::to_string(pid) + "/task";
  std::vector<ThreadSchedInfo> out;
  DIR* dir = ::opendir(base.c_str());
  if (!dir) return out;
  while (dirent* e = ::readdir(dir)) {
    if (e->d_name[0] < '0' || e->d_name[0] > '9') continue;
    std::ifstream f(base + "/" + e->d_name + "/stat");
    std::string line;
    if (!std::getline(f, line)) continue;
    // comm is in parentheses and may hold spaces: fields count from the last ')'.
    const auto open = line.find('(');
    const auto close = line.rfind(')');
    if (open == std::string::npos || close == std::string::npos) continue;
    ThreadSchedInfo t;
    t.tid = std::atoi(e->d_name);
    t.name = line.substr(open + 1, close - open - 1);
    std::istringstream rest(line.substr(close + 2));
    std::vector<std::string> fields;  // fields[0] is field 3 (state)
    for (std::string s; rest >> s;)
      fields.push_back(s);
    // Field 40 is rt_priority, field 41 policy (proc(5)).
    if (fields.size() >= 39) {
      t.rt_priority = std::atoi(fields[40 - 3].c_str());
      t.policy = std::atoi(fields[41 - 3].c_str());
    }
    out.push_back(t);
  }
  ::closedir(dir);
  return out;
}

std::vector<ThreadSchedInfo> realtime_threads() {
  std::vector<ThreadSchedInfo> out;
  for (const auto& t : process_threads())
    if (t.policy == SCHED_FIFO || t.policy == SCHED_RR) out.push_back(t);
  return out;
}

}  // namespace rosguard::hw

#include "hw/housekeeping.h"

#include <dirent.h>
#include <pthread.h>

#include <algorithm>
#include <fstream>
#include <mutex>

#include "hw/common/sys.h"

namespace rosguard::hw {
namespace {

std::mutex g_mutex;
std::vector<int> g_cpus;  // what the live HousekeepingPin holds

std::string list(const std::set<int>& s) {
  return cpu_ranges(std::vector<int>(s.begin(), s.end()));
}

}  // namespace

std::string cpu_ranges(const std::vector<int>& cpus) {
  if (cpus.empty()) return "none";
  std::vector<int> v = cpus;
  std::sort(v.begin(), v.end());
  std::string out;
  for (std::size_t i = 0; i < v.size();) {
    std::size_t j = i;
    while (j + 1 < v.size() && v[j + 1] == v[j] + 1)
      ++j;
    out += (out.empty() ? "" : ", ") + std::to_string(v[i]);
    if (j > i) out += "-" + std::to_string(v[j]);
    i = j + 1;
  }
  return out;
}

HousekeepingPlan plan_housekeeping(const std::vector<int>& usable, const std::set<int>& measured,
                                   const std::set<int>& controller) {
  HousekeepingPlan p;
  std::vector<int> spare, own;
  for (int c : usable) {
    if (measured.count(c)) continue;
    (controller.count(c) ? own : spare).push_back(c);
  }
  if (!spare.empty()) {
    p.kind = HousekeepingPlan::Kind::Spare;
    p.cpus = spare;
    p.detail = "CPU " + cpu_ranges(spare) + ": no node of the run uses " +
               (spare.size() == 1 ? "it" : "them") + " (RT / nRT cores " + list(measured) +
               ", controller " + list(controller) + ")";
  } else if (!own.empty()) {
    p.kind = HousekeepingPlan::Kind::Controller;
    p.cpus = own;
    p.detail = "CPU " + cpu_ranges(own) + ", the controller's, which no RT / nRT node uses (no " +
               "spare CPU: RT / nRT cores " + list(measured) + ")";
  } else {
    for (int c : usable)
      if (controller.count(c)) p.cpus.push_back(c);
    if (p.cpus.empty()) {
      p.detail = "left unpinned: no usable CPU is the controller's or spare";
      return p;
    }
    p.kind = HousekeepingPlan::Kind::SharedController;
    p.detail = "CPU " + cpu_ranges(p.cpus) +
               ", the controller's, which an RT / nRT node shares: every usable CPU runs a node "
               "(RT / nRT cores " +
               list(measured) +
               "); rosguard's own threads sleep while a point or baseline runs, but a host with "
               "a CPU to spare keeps them off the measured cores entirely";
  }
  return p;
}

HousekeepingPin::HousekeepingPin(const std::vector<int>& cpus) {
  if (cpus.empty()) return;
  const std::vector<int> usable = usable_cpus();
  CPU_ZERO(&old_);
  ::pthread_getaffinity_np(::pthread_self(), sizeof old_, &old_);
  cpu_set_t set;
  CPU_ZERO(&set);
  for (int c : cpus)
    CPU_SET(c, &set);
  if (const int err = ::pthread_setaffinity_np(::pthread_self(), sizeof set, &set); err != 0) {
    error_ = "cannot pin rosguard's own threads to CPU " + cpu_ranges(cpus) + " (" +
             errno_text(err) + ")";
    return;
  }
  pinned_ = true;
  set_usable_cpus_override(usable);
  const std::lock_guard lock(g_mutex);
  g_cpus = cpus;
}

HousekeepingPin::~HousekeepingPin() {
  if (!pinned_) return;
  ::pthread_setaffinity_np(::pthread_self(), sizeof old_, &old_);
  set_usable_cpus_override({});
  const std::lock_guard lock(g_mutex);
  g_cpus.clear();
}

std::vector<int> housekeeping_cpus() {
  const std::lock_guard lock(g_mutex);
  return g_cpus;
}

std::vector<ThreadPlacement> thread_placements() {
  std::vector<ThreadPlacement> out;
  DIR* dir = ::opendir("/proc/self/task");
  if (!dir) return out;
  while (dirent* e = ::readdir(dir)) {
    if (e->d_name[0] < '0' || e->d_name[0] > '9') continue;
    ThreadPlacement t;
    t.tid = static_cast<pid_t>(std::stol(e->d_name));
    std::ifstream comm(std::string("/proc/self/task/") + e->d_name + "/comm");
    std::getline(comm, t.name);
    cpu_set_t set;
    CPU_ZERO(&set);
    if (::sched_getaffinity(t.tid, sizeof set, &set) != 0) continue;  // it ended meanwhile
    for (int c = 0; c < CPU_SETSIZE; ++c)
      if (CPU_ISSET(c, &set)) t.cpus.push_back(c);
    out.push_back(std::move(t));
  }
  ::closedir(dir);
  std::sort(out.begin(), out.end(),
            [](const ThreadPlacement& a, const ThreadPlacement& b) { return a.tid < b.tid; });
  return out;
}

}  // namespace rosguard::hw

#include "load/host_facts.h"

#include <sched.h>
#include <sys/utsname.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <sstream>

#include "version.h"

namespace rosguard {
using json = nlohmann::json;

std::string iso_time_now() {
  const auto now = std::chrono::system_clock::now();
  const std::time_t t = std::chrono::system_clock::to_time_t(now);
  std::tm tm{};
  ::gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

json host_facts() {
  json h;
  utsname u{};
  if (::uname(&u) == 0) {
    h["hostname"] = u.nodename;
    h["kernel"] = std::string(u.sysname) + " " + u.release;
    h["machine"] = u.machine;
  }
  h["cpus_online"] = ::sysconf(_SC_NPROCESSORS_ONLN);
  std::ifstream cpuinfo("/proc/cpuinfo");
  std::string line;
  while (std::getline(cpuinfo, line)) {
    if (line.rfind("model name", 0) == 0 || line.rfind("Hardware", 0) == 0) {
      h["cpu_model"] = line.substr(line.find(':') + 2);
      break;
    }
  }
  return h;
}

namespace {

std::string first_line(const std::string& path) {
  std::ifstream f(path);
  std::string s;
  if (f) std::getline(f, s);
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ' || s.back() == '\r'))
    s.pop_back();
  return s;
}

// "48K" -> 48, "1M" -> 1024 (sysfs cache sizes).
double size_kb(const std::string& text) {
  if (text.empty()) return 0.0;
  try {
    std::size_t used = 0;
    const double v = std::stod(text, &used);
    const char unit = used < text.size() ? text[used] : 'B';
    if (unit == 'K' || unit == 'k') return v;
    if (unit == 'M' || unit == 'm') return v * 1024.0;
    if (unit == 'G' || unit == 'g') return v * 1024.0 * 1024.0;
    return v / 1024.0;
  } catch (const std::exception&) {
    return 0.0;
  }
}

// As hw/common/sys.cpp usable_cpus(): in the affinity mask and online.
std::vector<int> usable_cpus() {
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

}  // namespace

calibration::MachineIdentity this_machine() {
  calibration::MachineIdentity id;
  std::string arch;
  utsname u{};
  if (::uname(&u) == 0) {
    id.hostname = u.nodename;
    id.kernel = std::string(u.sysname) + " " + u.release;
    arch = u.machine;
  }
  id.date = iso_time_now();
  const std::vector<int> cpus = usable_cpus();
  id.cpus = static_cast<int>(cpus.size());
  std::ifstream cpuinfo("/proc/cpuinfo");
  for (std::string line; std::getline(cpuinfo, line);)
    if (line.rfind("model name", 0) == 0 || line.rfind("Hardware", 0) == 0) {
      if (const auto colon = line.find(':'); colon != std::string::npos)
        id.cpu_model = line.substr(std::min(line.size(), colon + 2));
      break;
    }
  if (id.cpu_model.empty()) id.cpu_model = "unknown (" + arch + ")";
  if (cpus.empty()) return id;
  // The caches of the first usable CPU (hw/host_probe.cpp probe_caches).
  bool any = false;
  for (int i = 0; i < 16; ++i) {
    const std::string dir = "/sys/devices/system/cpu/cpu" + std::to_string(cpus.front()) +
                            "/cache/index" + std::to_string(i);
    const std::string level_text = first_line(dir + "/level");
    if (level_text.empty()) break;
    int level = 0;
    try {
      level = std::stoi(level_text);
      const std::string line = first_line(dir + "/coherency_line_size");
      if (!line.empty()) (void)std::stoi(line);  // the probe skips an entry it cannot parse
    } catch (const std::exception&) {
      continue;
    }
    any = true;
    const std::string type = first_line(dir + "/type");
    const double kb = size_kb(first_line(dir + "/size"));
    if (level == 1 && type == "Data") id.l1d_kb = kb;
    if (level == 2 && type != "Instruction") id.l2_kb = kb;
    if (level == 3 && type != "Instruction") id.l3_kb_per_cluster = kb;
  }
  if (!any) {
    id.l1d_kb = static_cast<double>(std::max(0L, ::sysconf(_SC_LEVEL1_DCACHE_SIZE))) / 1024.0;
    id.l2_kb = static_cast<double>(std::max(0L, ::sysconf(_SC_LEVEL2_CACHE_SIZE))) / 1024.0;
    id.l3_kb_per_cluster =
        static_cast<double>(std::max(0L, ::sysconf(_SC_LEVEL3_CACHE_SIZE))) / 1024.0;
  }
  return id;
}

std::optional<unsigned long long> process_start_ticks(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string stat;
  if (!std::getline(in, stat)) return std::nullopt;
  // The command name (field 2) may hold spaces and parentheses: count fields after the last ')'.
  const auto close = stat.rfind(')');
  if (close == std::string::npos) return std::nullopt;
  std::istringstream fields(stat.substr(close + 1));
  std::string field;
  for (int i = 3; i <= 22; ++i)
    if (!(fields >> field)) return std::nullopt;
  try {
    return std::stoull(field);
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

json process_facts() {
  json p;
  utsname u{};
  if (::uname(&u) == 0) p["host"] = u.nodename;
  p["pid"] = ::getpid();
  if (const auto ticks = process_start_ticks(::getpid())) p["pid_start"] = *ticks;
  const auto env = [](const char* name) -> std::string {
    const char* v = std::getenv(name);
    return v ? v : "";
  };
  if (const std::string array = env("SLURM_ARRAY_JOB_ID"), task = env("SLURM_ARRAY_TASK_ID");
      !array.empty() && !task.empty())
    p["slurm_job"] = array + "_" + task;
  else if (const std::string job = env("SLURM_JOB_ID"); !job.empty())
    p["slurm_job"] = job;
  return p;
}

// The revision is the one baked in when the build was configured: an installed rosguard has no
// source tree to ask, and a results folder must not depend on where it was written from.
json tool_facts() {
  return {{"name", "rosguard"},
          {"version", kVersion},
          {"git_revision", kGitRevision},
          {"build_type", kBuildType}};
}

}  // namespace rosguard

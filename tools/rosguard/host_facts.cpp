#include "host_facts.h"

#include <sys/utsname.h>
#include <unistd.h>

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

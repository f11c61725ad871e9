#include "host_facts.h"

#include <sys/utsname.h>
#include <unistd.h>

#include <chrono>
#include <ctime>
#include <fstream>

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

// The revision is the one baked in when the build was configured: an installed rosguard has no
// source tree to ask, and a results folder must not depend on where it was written from.
json tool_facts() {
  return {{"name", "rosguard"},
          {"version", kVersion},
          {"git_revision", kGitRevision},
          {"build_type", kBuildType}};
}

}  // namespace rosguard

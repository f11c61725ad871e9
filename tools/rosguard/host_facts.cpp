#include "host_facts.h"

#include <sys/utsname.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <ctime>
#include <fstream>

#include "version.h"

namespace rosguard {
using json = nlohmann::json;

namespace {

// stdout of a shell command, trailing newlines and spaces cut; empty when it cannot run.
std::string run_capture(const std::string& cmd) {
  std::string out;
  if (FILE* p = ::popen(cmd.c_str(), "r")) {
    char buf[256];
    while (std::fgets(buf, sizeof buf, p))
      out += buf;
    ::pclose(p);
  }
  while (!out.empty() && (out.back() == '\n' || out.back() == ' '))
    out.pop_back();
  return out;
}

}  // namespace

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

json tool_facts(const Home& home) {
  const std::string dir = "'" + home.root.string() + "'";
  std::string rev = run_capture("git -C " + dir + " rev-parse --short=12 HEAD 2>/dev/null");
  if (rev.empty())
    rev = "unknown";
  else if (!run_capture("git -C " + dir + " status --porcelain --untracked-files=no 2>/dev/null")
                .empty())
    rev += "-dirty";
  return {{"name", "rosguard"},
          {"version", kVersion},
          {"git_revision", rev},
          {"build_type", kBuildType}};
}

}  // namespace rosguard

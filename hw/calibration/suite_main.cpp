// rosguard-hw-suite: runs the calibration microbenchmark suite alone (developers; `rosguard
// calibrate` calls run_suite() itself) and writes {"measurements", "notes", "stopped"} as JSON.
//
//   rosguard-hw-suite [--quick] [--cores 0,1,...] [--out F.json]
//
// The host facts come from a minimal sysfs read here (cache sizes of CPU 0, the CPUs sharing its
// last-level cache), not from `rosguard platform probe`.
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>

#include "core/error.h"
#include "hw/calibration/suite.h"
#include "hw/common/sys.h"
#include "results/results.h"

namespace {

std::atomic<bool> g_stop{false};

extern "C" void on_sigint(int) {
  g_stop.store(true);
}

std::string read_line(const std::string& path) {
  std::ifstream f(path);
  std::string s;
  std::getline(f, s);
  return s;
}

// "48K", "2048K", "32M" -> KB.
double size_kb(const std::string& s) {
  if (s.empty()) return 0.0;
  const double v = std::stod(s);
  if (s.back() == 'M') return v * 1024.0;
  if (s.back() == 'G') return v * 1024.0 * 1024.0;
  return v;
}

// How many CPUs a sysfs list ("0-3,8") names.
int list_count(const std::string& list) {
  int n = 0;
  std::stringstream ss(list);
  std::string part;
  while (std::getline(ss, part, ',')) {
    const auto dash = part.find('-');
    n += dash == std::string::npos ? 1 : std::stoi(part.substr(dash + 1)) - std::stoi(part) + 1;
  }
  return n;
}

rosguard::calibration::HostFacts sysfs_host() {
  rosguard::calibration::HostFacts h;
  char name[256] = {};
  ::gethostname(name, sizeof name - 1);
  h.hostname = name;
  std::ifstream cpuinfo("/proc/cpuinfo");
  for (std::string line; std::getline(cpuinfo, line);)
    if (line.rfind("model name", 0) == 0 && line.find(':') != std::string::npos) {
      h.cpu_model = line.substr(line.find(':') + 2);
      break;
    }
  h.cpus = static_cast<int>(rosguard::hw::usable_cpus().size());
  h.cores_per_cluster = h.cpus;
  for (int i = 0; i < 8; ++i) {
    const std::string base = "/sys/devices/system/cpu/cpu0/cache/index" + std::to_string(i) + "/";
    const std::string level = read_line(base + "level");
    if (level.empty()) continue;
    const std::string type = read_line(base + "type");
    const double kb = size_kb(read_line(base + "size"));
    if (level == "1" && type == "Data") h.l1d_kb = kb;
    if (level == "2") h.l2_kb = kb;
    if (level == "3") {
      h.l3_kb_per_cluster = kb;
      h.cores_per_cluster = std::max(1, list_count(read_line(base + "shared_cpu_list")));
    }
  }
  h.clusters = std::max(1, h.cpus / std::max(1, h.cores_per_cluster));
  const std::string khz = read_line("/sys/devices/system/cpu/cpu0/cpufreq/cpuinfo_max_freq");
  if (!khz.empty()) h.freq_mhz = std::stod(khz) / 1000.0;
  return h;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace rosguard;
  hw::SuiteOptions opt;
  std::string out;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quick") {
      opt.quick = true;
    } else if (a == "--out" && i + 1 < argc) {
      out = argv[++i];
    } else if (a == "--cores" && i + 1 < argc) {
      std::stringstream ss(argv[++i]);
      for (std::string c; std::getline(ss, c, ',');)
        opt.cores.push_back(std::stoi(c));
    } else {
      std::cerr << "usage: rosguard-hw-suite [--quick] [--cores 0,1,...] [--out F.json]\n";
      return 2;
    }
  }
  struct sigaction sa {};
  sa.sa_handler = on_sigint;
  ::sigaction(SIGINT, &sa, nullptr);
  opt.stop = &g_stop;
  opt.host = sysfs_host();
  const bool tty = ::isatty(STDERR_FILENO);
  opt.progress = [tty](int step, int steps, const std::string& what) {
    std::cerr << (tty ? "\r\033[K" : "") << "[" << step << "/" << steps << "] " << what
              << (tty ? "" : "\n") << std::flush;
  };
  try {
    const auto r = hw::run_suite(opt);
    if (tty) std::cerr << "\n";
    const auto& m = r.measurements;
    std::printf("host %s: %d CPUs, L2 %.0f KB, L3 %.0f KB; wall %.1f s%s\n",
                m.host.cpu_model.c_str(), m.host.cpus, m.host.l2_kb, m.host.l3_kb_per_cluster,
                m.wall_s, r.stopped ? " (stopped: partial)" : "");
    for (const auto& n : r.notes)
      std::printf("note: %s\n", n.c_str());
    std::map<std::pair<std::string, double>, double> alone;
    for (const auto& k : m.runs)
      if (k.corunners.empty()) alone[{k.kernel, k.working_set_kb}] = k.ns_per_line;
    for (const auto& k : m.runs) {
      std::printf("%-16s %8.0f KB %6.2f ns/line cv %5.3f n %2d", k.kernel.c_str(), k.working_set_kb,
                  k.ns_per_line, k.cv, k.samples);
      if (k.ci95_pct)
        std::printf(" ci95 +-%4.1f %%", *k.ci95_pct);
      else
        std::printf(" ci95     -  ");
      if (!k.corunners.empty()) {
        const auto& c = k.corunners.front();
        std::printf("  with %zux %s %.0f KB: slowdown %.3f", k.corunners.size(), c.kernel.c_str(),
                    c.working_set_kb, k.ns_per_line / alone[{k.kernel, k.working_set_kb}]);
      }
      std::printf("\n");
    }
    for (const auto& [name, v] : m.costs_us)
      std::printf("cost %-20s median %8.2f us  (%zu samples)\n", name.c_str(),
                  v.empty() ? 0.0 : median(v), v.size());
    if (!out.empty()) {
      nlohmann::json j;
      j["measurements"] = m;
      j["notes"] = r.notes;
      j["stopped"] = r.stopped;
      std::ofstream f(out);
      f << j.dump(2) << "\n";
      if (!f) throw RunError("cannot write " + out);
    }
    return r.stopped ? 130 : 0;
  } catch (const std::exception& e) {
    std::cerr << "rosguard-hw-suite: " << e.what() << "\n";
    return 1;
  }
}

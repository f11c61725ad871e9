// Probing the host (hw/host_probe.h). Cache topology comes from sysfs
// (/sys/devices/system/cpu/cpuN/cache/indexM), which is also what hwloc reads on Linux; reading
// it directly keeps the hw backend free of a shared-library dependency that a carried build may
// not find on another machine.
#include "hw/host_probe.h"

#include <pthread.h>
#include <sched.h>
#include <sys/utsname.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <ctime>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <thread>

#include "core/error.h"
#include "core/types.h"
#include "hw/common/sys.h"
#include "hw/executor/executor.h"
#include "hw/pmc_source/perf.h"
#include "hw/pmc_source/perf_events.h"
#include "hw/workload/work_counters.h"
#include "hw/workload/workload.h"
#include "results/results.h"

namespace rosguard::hw {
namespace {

using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

const std::string kCpuSys = "/sys/devices/system/cpu";

std::string read_line(const std::string& path) {
  std::ifstream f(path);
  std::string s;
  if (f) std::getline(f, s);
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ' || s.back() == '\r'))
    s.pop_back();
  return s;
}

// "48K" -> 48, "1M" -> 1024, "32768K" -> 32768.
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

std::vector<CacheInfo> caches_of(int cpu) {
  std::vector<CacheInfo> out;
  for (int i = 0; i < 16; ++i) {
    const std::string dir =
        kCpuSys + "/cpu" + std::to_string(cpu) + "/cache/index" + std::to_string(i);
    const std::string level = read_line(dir + "/level");
    if (level.empty()) break;
    CacheInfo c;
    try {
      c.level = std::stoi(level);
      const std::string line = read_line(dir + "/coherency_line_size");
      c.line_bytes = line.empty() ? 0 : std::stoi(line);
    } catch (const std::exception&) {
      continue;
    }
    c.type = read_line(dir + "/type");
    c.size_kb = size_kb(read_line(dir + "/size"));
    c.shared_cpus = parse_cpu_list(read_line(dir + "/shared_cpu_list"));
    if (c.shared_cpus.empty()) c.shared_cpus = {cpu};
    out.push_back(std::move(c));
  }
  return out;
}

std::string iso_now() {
  const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  ::gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

std::string fixed(double v, int digits) {
  std::ostringstream os;
  os.setf(std::ios::fixed);
  os.precision(digits);
  os << v;
  return os.str();
}

void probe_identity(HostProbe& p) {
  utsname u{};
  if (::uname(&u) == 0) {
    p.hostname = u.nodename;
    p.kernel = std::string(u.sysname) + " " + u.release;
    p.arch = u.machine;
  }
  p.date = iso_now();
  p.online_cpus = static_cast<int>(::sysconf(_SC_NPROCESSORS_ONLN));
  p.usable_cpus = usable_cpus();
  std::ifstream cpuinfo("/proc/cpuinfo");
  for (std::string line; std::getline(cpuinfo, line);)
    if (line.rfind("model name", 0) == 0 || line.rfind("Hardware", 0) == 0) {
      if (const auto colon = line.find(':'); colon != std::string::npos)
        p.cpu_model = line.substr(std::min(line.size(), colon + 2));
      break;
    }
  if (p.cpu_model.empty()) p.cpu_model = "unknown (" + p.arch + ")";
  if (static_cast<int>(p.usable_cpus.size()) < p.online_cpus)
    p.notes.push_back("this process may use " + std::to_string(p.usable_cpus.size()) + " of the " +
                      std::to_string(p.online_cpus) + " online CPUs (CPUs " +
                      cpu_list_text(p.usable_cpus) +
                      ", affinity mask or cgroup cpuset): the platform describes those");
}

void probe_caches(HostProbe& p) {
  if (p.usable_cpus.empty()) return;
  const std::vector<CacheInfo> first = caches_of(p.usable_cpus.front());
  if (first.empty()) {
    // No sysfs cache information (some containers and ARM firmware): glibc's view, else none.
    p.line_bytes = static_cast<int>(::sysconf(_SC_LEVEL1_DCACHE_LINESIZE));
    p.l1d_kb = static_cast<double>(std::max(0L, ::sysconf(_SC_LEVEL1_DCACHE_SIZE))) / 1024.0;
    p.l2_kb = static_cast<double>(std::max(0L, ::sysconf(_SC_LEVEL2_CACHE_SIZE))) / 1024.0;
    p.l3_kb_per_cluster =
        static_cast<double>(std::max(0L, ::sysconf(_SC_LEVEL3_CACHE_SIZE))) / 1024.0;
    if (p.line_bytes <= 0) p.line_bytes = 64;
    p.cache_source = "sysconf (glibc); the kernel reports no caches in sysfs";
    p.notes.push_back("no cache information in " + kCpuSys +
                      "/cpu*/cache: cache sizes from glibc's sysconf (0 = unknown), line size " +
                      std::to_string(p.line_bytes) +
                      " bytes, and every usable CPU taken as one cluster (the sharing is unknown)");
    p.clusters.push_back({p.usable_cpus, p.usable_cpus, 0, p.l3_kb_per_cluster});
    return;
  }
  for (const auto& c : first) {
    if (c.level == 1 && c.type == "Data") p.l1d_kb = c.size_kb;
    if (c.level == 1 && c.type == "Instruction") p.l1i_kb = c.size_kb;
    if (c.level == 2 && c.type != "Instruction") p.l2_kb = c.size_kb;
    if (c.level == 3 && c.type != "Instruction") p.l3_kb_per_cluster = c.size_kb;
    if (c.level == 1 && c.type == "Data" && c.line_bytes > 0) p.line_bytes = c.line_bytes;
  }
  p.cache_source = "sysfs " + kCpuSys + "/cpu*/cache/index*";

  // Clusters: the usable CPUs grouped by the CPU set of their last-level cache.
  std::map<std::vector<int>, CpuCluster> by_llc;
  std::set<double> llc_sizes;
  for (int cpu : p.usable_cpus) {
    const auto caches = caches_of(cpu);
    const CacheInfo* llc = nullptr;
    for (const auto& c : caches)
      if (c.type != "Instruction" && (!llc || c.level > llc->level)) llc = &c;
    const std::vector<int> key = llc ? llc->shared_cpus : std::vector<int>{cpu};
    auto& cl = by_llc[key];
    cl.cpus.push_back(cpu);
    cl.all_cpus = key;
    cl.llc_level = llc ? llc->level : 0;
    cl.llc_kb = llc ? llc->size_kb : 0.0;
    llc_sizes.insert(cl.llc_kb);
  }
  for (auto& [_, cl] : by_llc)
    p.clusters.push_back(std::move(cl));
  std::sort(p.clusters.begin(), p.clusters.end(),
            [](const CpuCluster& a, const CpuCluster& b) { return a.cpus[0] < b.cpus[0]; });

  if (p.l3_kb_per_cluster == 0.0)
    p.notes.push_back("no level-3 cache reported: the clusters are the CPUs sharing the level-" +
                      std::to_string(p.clusters.front().llc_level) + " cache");
  std::set<std::size_t> sizes;
  for (const auto& cl : p.clusters)
    sizes.insert(cl.cpus.size());
  if (sizes.size() > 1 || llc_sizes.size() > 1) {
    std::string desc;
    for (const auto& cl : p.clusters)
      desc +=
          (desc.empty() ? "" : "; ") + cpu_list_text(cl.cpus) + " (" + fixed(cl.llc_kb, 0) + " KB)";
    p.notes.push_back("the clusters are unequal (usable CPUs per last-level cache: " + desc + ")");
  }
  for (const auto& cl : p.clusters)
    if (cl.cpus.size() < cl.all_cpus.size())
      p.notes.push_back("CPUs " + cpu_list_text(cl.all_cpus) +
                        " share a last-level cache, of which this process may use " +
                        cpu_list_text(cl.cpus));
}

// A dependent add chain runs at about one add per cycle on current cores: an estimate of the
// clock, used only when the kernel reports no frequency.
double estimate_mhz() {
  std::uint64_t x = 0;
  constexpr std::uint64_t kIterations = 200'000'000;
  const auto t0 = Clock::now();
  for (std::uint64_t i = 0; i < kIterations; ++i) {
    x += i;
    asm volatile("" : "+r"(x));
  }
  const double s = std::chrono::duration<double>(Clock::now() - t0).count();
  return s > 0 ? static_cast<double>(kIterations) / s / 1e6 : 0.0;
}

void probe_frequency(HostProbe& p) {
  const int cpu = p.usable_cpus.empty() ? 0 : p.usable_cpus.front();
  std::set<std::string> maxima;
  for (int c : p.usable_cpus)
    if (const auto f =
            read_line(kCpuSys + "/cpu" + std::to_string(c) + "/cpufreq/cpuinfo_max_freq");
        !f.empty())
      maxima.insert(f);
  const std::string max_khz =
      read_line(kCpuSys + "/cpu" + std::to_string(cpu) + "/cpufreq/cpuinfo_max_freq");
  if (!max_khz.empty()) {
    try {
      p.freq_mhz = std::stod(max_khz) / 1000.0;
      p.freq_source = "cpufreq cpuinfo_max_freq of CPU " + std::to_string(cpu);
      if (maxima.size() > 1)
        p.notes.push_back("the usable CPUs have different maximum frequencies (" +
                          std::to_string(maxima.size()) + " values in cpufreq); freq_mhz is CPU " +
                          std::to_string(cpu) + "'s");
      return;
    } catch (const std::exception&) {
    }
  }
  // /proc/cpuinfo "cpu MHz" (x86): the current clock of each CPU, in CPU order.
  std::ifstream cpuinfo("/proc/cpuinfo");
  int processor = -1;
  for (std::string line; std::getline(cpuinfo, line);) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    if (line.rfind("processor", 0) == 0) {
      try {
        processor = std::stoi(line.substr(colon + 1));
      } catch (const std::exception&) {
      }
    }
    if (line.rfind("cpu MHz", 0) == 0 && processor == cpu) {
      try {
        p.freq_mhz = std::stod(line.substr(colon + 1));
        p.freq_source = "/proc/cpuinfo 'cpu MHz' of CPU " + std::to_string(cpu) +
                        " (no cpufreq in sysfs: the current clock, as the hypervisor or firmware "
                        "reports it)";
        return;
      } catch (const std::exception&) {
      }
    }
  }
  p.freq_mhz = estimate_mhz();
  p.freq_source =
      "estimated from a timed dependent-add loop (one add per cycle assumed): the "
      "kernel reports no frequency (no cpufreq, no 'cpu MHz')";
  p.notes.push_back("no CPU frequency reported by the kernel; freq_mhz " + fixed(p.freq_mhz, 0) +
                    " is an estimate from a timed loop");
}

void probe_events(HostProbe& p) {
  const Arch arch = host_arch();
  const auto implemented = arch == Arch::Aarch64 ? armv8_pmu_events() : std::nullopt;
  std::string unimplemented;
  for (const auto& name : hardware_event_names()) {
    EventProbe e{name, false, ""};
    const auto code = hardware_event(name, arch);
    if (!code) {
      e.detail = "no code for this event on " + std::string(to_string(arch));
    } else {
      try {
        open_perf_group({{name, *code}}, PmcTarget{});
        const auto why = pmu_lacks(*code, implemented);
        e.opens = !why;
        e.detail = why ? *why : std::string(code->note);
        if (why) unimplemented += (unimplemented.empty() ? "" : ", ") + name;
      } catch (const RunError& err) {
        e.detail = err.what();
      }
    }
    p.hardware_events.push_back(std::move(e));
  }
  if (!unimplemented.empty())
    p.notes.push_back("hardware events that open but the PMU does not implement (not in " +
                      implemented->where + "; they would count 0): " + unimplemented);
  for (const auto& name : software_event_names()) {
    EventProbe e{name, false, ""};
    try {
      open_perf_group({{name, *software_event(name)}}, PmcTarget{});
      e.opens = true;
      e.detail = std::string(software_event(name)->note);
    } catch (const RunError& err) {
      e.detail = err.what();
    }
    p.software_events.push_back(std::move(e));
  }
  const bool any = std::any_of(p.hardware_events.begin(), p.hardware_events.end(),
                               [](const EventProbe& e) { return e.opens; });
  if (!any)
    p.notes.push_back("no hardware PMU event opens here (" +
                      (p.hardware_events.empty() ? std::string("none named for this architecture")
                                                 : p.hardware_events.front().detail) +
                      "): regulation counts with the instrumented source (built-in kernels) or "
                      "the software source (a time-based budget)");
}

// SCHED_FIFO on a thread that does nothing else and ends at once.
void probe_sched_fifo(HostProbe& p) {
  int rc = 0;
  std::thread t([&rc] {
    sched_param sp{};
    sp.sched_priority = 1;
    rc = ::pthread_setschedparam(::pthread_self(), SCHED_FIFO, &sp);
  });
  t.join();
  p.sched_fifo = rc == 0;
  p.sched_fifo_detail = rc == 0
                            ? "SCHED_FIFO priority 1 set on a short-lived thread"
                            : "pthread_setschedparam(SCHED_FIFO, 1) refused: " + errno_text(rc) +
                                  " (the hw backend falls back to SCHED_OTHER with nice "
                                  "values, and says so)";
  if (rc != 0) p.notes.push_back("SCHED_FIFO is not available: " + errno_text(rc));
}

// bandwidth_read (2048 KB, one load per line) alone on `cpu` (SCHED_OTHER): a warm-up, then
// kRuns runs of about 40 ms each; MiB/s per run, median.
ReferenceRun measure_reference(int cpu) {
  // The kernel touches one 64-byte line per work unit (hw/workload/kernels.cpp), whatever the
  // host's line size.
  constexpr double kBytesPerUnit = 64;
  constexpr double kWorkingSetKb = 2048;
  constexpr int kRuns = 7;
  constexpr double kRunMs = 40.0, kWarmUpMs = 100.0;
  ReferenceRun r;
  r.cpu = cpu;
  r.working_set_kb = kWorkingSetKb;
  const auto t_start = Clock::now();
  std::exception_ptr error;
  std::thread worker([&] {
    try {
      r.pinned = apply_to_current_thread({"rg-probe-bw", cpu, SchedClass::Other, prio::kNct},
                                         system_sched_ops())
                     .pinned;
      const auto make = [&](std::uint64_t passes) {
        WorkloadInfo w{"bandwidth_read", "rosguard platform probe",
                       json{{"name", "bandwidth_read"},
                            {"hw",
                             {{"kernel", "bandwidth_read"},
                              {"working_set_kb", static_cast<std::size_t>(kWorkingSetKb)},
                              {"passes", passes}}}}};
        return make_builtin_workload(w);
      };
      const std::atomic<bool> stop{false};
      WorkCounters counters;
      // Size the runs from the fastest of 20-pass trials over a 100 ms warm-up: a trial the
      // host preempted would make every run longer than planned.
      auto probe = make(20);
      double ns_per_pass = 1e18;
      const auto warm_until = Clock::now() + std::chrono::duration<double, std::milli>(kWarmUpMs);
      do {
        const auto t0 = Clock::now();
        probe->run(stop, counters);
        ns_per_pass =
            std::min(ns_per_pass,
                     std::chrono::duration<double, std::nano>(Clock::now() - t0).count() / 20.0);
      } while (Clock::now() < warm_until);
      r.passes = std::max<std::uint64_t>(
          1, static_cast<std::uint64_t>(kRunMs * 1e6 / std::max(ns_per_pass, 1.0)));
      auto run = make(r.passes);
      const double bytes = static_cast<double>(run->units_per_run()) * kBytesPerUnit;
      for (int i = 0; i < kRuns; ++i) {
        const auto t0 = Clock::now();
        run->run(stop, counters);
        const double s = std::chrono::duration<double>(Clock::now() - t0).count();
        r.run_mbps.push_back(bytes / s / kBytesPerMb);
      }
    } catch (...) {
      error = std::current_exception();
    }
  });
  worker.join();
  if (error) std::rethrow_exception(error);
  r.mbps = median(r.run_mbps);
  r.wall_ms = std::chrono::duration<double, std::milli>(Clock::now() - t_start).count();
  return r;
}

json events_json(const std::vector<EventProbe>& events) {
  json a = json::array();
  for (const auto& e : events)
    a.push_back({{"name", e.name}, {"opens", e.opens}, {"detail", e.detail}});
  return a;
}

std::string kb_text(double kb) {
  return kb == 0.0 ? "not reported" : fixed(kb, 0) + " KB";
}

}  // namespace

HostProbe probe_host(const ProbeOptions& options) {
  HostProbe p;
  probe_identity(p);
  if (p.usable_cpus.empty())
    throw RunError("probing the host: sched_getaffinity names no usable online CPU");
  probe_caches(p);
  probe_frequency(p);
  probe_events(p);
  probe_sched_fifo(p);
  // The last usable CPU: on small machines CPU 0 takes most interrupts and housekeeping.
  if (options.measure_reference) p.reference = measure_reference(p.usable_cpus.back());
  return p;
}

json to_json(const HostProbe& p) {
  json clusters = json::array();
  for (const auto& c : p.clusters)
    clusters.push_back({{"cpus", c.cpus},
                        {"shares_llc_with", c.all_cpus},
                        {"llc_level", c.llc_level},
                        {"llc_kb", c.llc_kb}});
  json j{{"hostname", p.hostname},
         {"kernel", p.kernel},
         {"arch", p.arch},
         {"cpu_model", p.cpu_model},
         {"date", p.date},
         {"online_cpus", p.online_cpus},
         {"usable_cpus", p.usable_cpus},
         {"clusters", clusters},
         {"caches",
          {{"l1d_kb", p.l1d_kb},
           {"l1i_kb", p.l1i_kb},
           {"l2_kb", p.l2_kb},
           {"l3_kb_per_cluster", p.l3_kb_per_cluster},
           {"line_bytes", p.line_bytes},
           {"source", p.cache_source}}},
         {"freq_mhz", p.freq_mhz},
         {"freq_source", p.freq_source},
         {"hardware_events", events_json(p.hardware_events)},
         {"software_events", events_json(p.software_events)},
         {"sched_fifo", {{"available", p.sched_fifo}, {"detail", p.sched_fifo_detail}}},
         {"notes", p.notes}};
  if (p.reference)
    j["reference"] = {{"mbps", p.reference->mbps},
                      {"run_mbps", p.reference->run_mbps},
                      {"cpu", p.reference->cpu},
                      {"pinned", p.reference->pinned},
                      {"working_set_kb", p.reference->working_set_kb},
                      {"passes", p.reference->passes},
                      {"wall_ms", p.reference->wall_ms}};
  return j;
}

namespace {

// Scenario cores are Linux CPU numbers on the hw backend. The platform is exact when the
// usable CPUs are 0..n-1 in equal clusters numbered in order; otherwise one cluster spanning
// CPU 0 to the highest usable CPU, so that a scenario can name every usable CPU (the hw backend
// refuses the others by name).
json cpu_section(const HostProbe& p, const std::string& where) {
  const int n = static_cast<int>(p.usable_cpus.size());
  bool exact = p.usable_cpus.back() == n - 1 && !p.clusters.empty() &&
               n % static_cast<int>(p.clusters.size()) == 0;
  const int per = exact ? n / static_cast<int>(p.clusters.size()) : 0;
  for (std::size_t k = 0; exact && k < p.clusters.size(); ++k) {
    const auto& cpus = p.clusters[k].cpus;
    exact = static_cast<int>(cpus.size()) == per;
    for (int i = 0; exact && i < per; ++i)
      exact = cpus[static_cast<std::size_t>(i)] == static_cast<int>(k) * per + i;
  }
  std::string cluster_text;
  for (const auto& c : p.clusters)
    cluster_text += (cluster_text.empty() ? "" : "; ") + cpu_list_text(c.cpus);
  json cpu{{"model", p.cpu_model},
           {"clusters", exact ? static_cast<int>(p.clusters.size()) : 1},
           {"cores_per_cluster", exact ? per : p.usable_cpus.back() + 1},
           {"freq_mhz", std::round(p.freq_mhz * 1000.0) / 1000.0}};
  cpu["source"] =
      where + ": usable CPUs " + cpu_list_text(p.usable_cpus) +
      " (sched_getaffinity, online), clusters = usable CPUs sharing a last-level cache (" +
      p.cache_source + "): " + cluster_text +
      (exact ? ""
             : " - the usable CPUs are not 0..n-1 in equal clusters numbered in order, so "
               "described as "
               "one cluster of CPUs 0-" +
                   std::to_string(p.usable_cpus.back()) +
                   " (scenario cores are Linux CPU numbers; the hw backend refuses "
                   "CPUs outside " +
                   cpu_list_text(p.usable_cpus) + ")") +
      "; freq_mhz: " + p.freq_source;
  return cpu;
}

// The caches of the first usable CPU.
json caches_section(const HostProbe& p, const std::string& where) {
  json caches{{"line_bytes", p.line_bytes}, {"l2_kb", p.l2_kb}};
  if (p.l1i_kb > 0) caches["l1i_kb"] = p.l1i_kb;
  if (p.l1d_kb > 0) caches["l1d_kb"] = p.l1d_kb;
  if (p.l3_kb_per_cluster > 0) caches["l3_kb_per_cluster"] = p.l3_kb_per_cluster;
  caches["source"] = where + " from " + p.cache_source + " of CPU " +
                     std::to_string(p.usable_cpus.front()) + ": L1d " + kb_text(p.l1d_kb) +
                     ", L2 " + kb_text(p.l2_kb) + ", L3 " + kb_text(p.l3_kb_per_cluster) +
                     " per cluster, " + std::to_string(p.line_bytes) + "-byte lines";
  return caches;
}

// The events a metric may name: the hardware events that open with perf_event_open, and the
// two the instrumented source counts for the built-in kernels on any host.
json pmu_section(const HostProbe& p, const std::string& where) {
  std::vector<std::string> events, opened;
  for (const auto& e : p.hardware_events)
    if (e.opens) opened.push_back(e.name);
  events = opened;
  for (const char* e : {"l2d_cache_refill", "l2d_cache_wb"})
    if (std::find(events.begin(), events.end(), e) == events.end()) events.emplace_back(e);
  std::string opened_text;
  for (const auto& e : opened)
    opened_text += (opened_text.empty() ? "" : ", ") + e;
  std::string failed = "none";
  for (const auto& e : p.hardware_events)
    if (!e.opens) {
      failed = e.detail;
      break;
    }
  return {
      {"events", events},
      {"counter_bits", 64},
      {"source",
       where + ": perf_event_open of each named hardware event on this thread: " +
           (opened.empty() ? "none opened (" + failed + ")" : "opened " + opened_text) +
           "; l2d_cache_refill and l2d_cache_wb are also counted by the hw backend's instrumented "
           "source (cache lines touched by the built-in kernels); 64-bit counts (perf accumulates "
           "into 64 bits)"}};
}

// The reference bandwidth and what the probe cannot measure (memory model, costs, kernels): from
// the installed model of this host, else the reference measured at probe time.
void model_sections(const HostProbe& p, const std::optional<InstalledModel>& installed,
                    const std::string& where, json& doc) {
  if (installed) {
    doc["reference"] = installed->doc.at("reference");
    doc["reference"]["source"] =
        "from the installed model of this host (" + installed->path +
        "): " + installed->doc.at("reference").at("source").get<std::string>();
    // The model's own sections (memory, costs, kernels, ...): what the probe cannot measure.
    for (const auto& [key, value] : installed->doc.items())
      if (!doc.contains(key) && key != "$schema") doc[key] = value;
  } else {
    const auto& r = *p.reference;
    std::string runs;
    for (double v : r.run_mbps)
      runs += (runs.empty() ? "" : ", ") + fixed(v, 0);
    doc["reference"] = {
        {"mbps", std::round(r.mbps * 100.0) / 100.0},
        {"source", "measured at probe time (" + where +
                       "; no calibrated model installed): "
                       "bandwidth_read (" +
                       fixed(r.working_set_kb, 0) + " KB working set, one load per 64-byte line, " +
                       std::to_string(r.passes) + " passes per run) alone on CPU " +
                       std::to_string(r.cpu) +
                       (r.pinned ? "" : " (asked; the pinning was refused)") +
                       " under SCHED_OTHER, after a 100 ms warm-up: median of " +
                       std::to_string(r.run_mbps.size()) + " runs (" + runs +
                       " MB/s); one short measurement, so it carries the host's noise at that "
                       "moment; rosguard calibrate --install measures it properly"}};
  }
}

}  // namespace

json host_platform_document(const HostProbe& p, const std::optional<InstalledModel>& installed) {
  if (!installed && !p.reference)
    throw ContractError(
        "host_platform_document: no installed host model and no measured reference bandwidth");
  const std::string where = "probed on " + p.hostname + " at " + p.date;
  json doc;
  doc["name"] = "host";
  doc["description"] = "This machine (" + p.hostname + ", " + p.cpu_model + ", " +
                       std::to_string(p.usable_cpus.size()) + " usable CPUs), " + where +
                       " by rosguard platform probe" +
                       (installed ? "; reference, memory model and costs from the calibrated "
                                    "model " +
                                        installed->path
                                  : "; no calibrated model installed, so no memory model or "
                                    "costs (the sim backend cannot run it)") +
                       (p.notes.empty() ? "" : ". Notes: " + [&] {
                         std::string s;
                         for (const auto& n : p.notes)
                           s += (s.empty() ? "" : "; ") + n;
                         return s;
                       }());

  doc["cpu"] = cpu_section(p, where);
  doc["caches"] = caches_section(p, where);
  doc["pmu"] = pmu_section(p, where);
  model_sections(p, installed, where, doc);
  return doc;
}

calibration::HostFacts host_facts(const HostProbe& p) {
  calibration::HostFacts f;
  f.hostname = p.hostname;
  f.cpu_model = p.cpu_model;
  f.cpus = static_cast<int>(p.usable_cpus.size());
  f.clusters = std::max<int>(1, static_cast<int>(p.clusters.size()));
  f.cores_per_cluster = f.cpus;
  for (const auto& c : p.clusters)
    f.cores_per_cluster = std::min(f.cores_per_cluster, static_cast<int>(c.cpus.size()));
  f.cores_per_cluster = std::max(1, f.cores_per_cluster);
  f.freq_mhz = p.freq_mhz;
  f.line_bytes = p.line_bytes;
  f.l1d_kb = p.l1d_kb;
  f.l2_kb = p.l2_kb;
  f.l3_kb_per_cluster = p.l3_kb_per_cluster;
  f.date = p.date;
  f.kernel = p.kernel;
  return f;
}

}  // namespace rosguard::hw

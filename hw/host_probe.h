// The machine rosguard runs on, as the hw backend can use it ("platform": "host",
// `rosguard platform probe`): usable CPUs, clusters of CPUs sharing a last-level cache, cache
// sizes, frequency, the PMU events that open, SCHED_FIFO availability, and (when no calibrated
// model of the host is installed) the reference bandwidth measured with the bandwidth_read kernel.
//
// Contract: probe_host() runs on the caller's thread and may start short-lived threads (the
// SCHED_FIFO trial, the bandwidth measurement), all joined before it returns; it reads /proc and
// /sys and opens perf events on the calling thread, changes nothing on the host, and never
// throws for a missing fact: what it cannot find is a note (and, where the platform needs a
// number, a stated fallback). host_platform_document() and host_facts() are pure.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "calibration/measurements.h"

namespace rosguard::hw {

// One cache as /sys/devices/system/cpu/cpuN/cache/indexM describes it.
struct CacheInfo {
  int level = 0;
  std::string type;  // "Data", "Instruction", "Unified"
  double size_kb = 0.0;
  int line_bytes = 0;
  std::vector<int> shared_cpus;  // shared_cpu_list
};

// The usable CPUs that share one last-level cache.
struct CpuCluster {
  std::vector<int> cpus;      // usable (online and in this process's affinity mask)
  std::vector<int> all_cpus;  // every CPU sharing the cache, usable or not
  int llc_level = 0;          // 0: no cache information
  double llc_kb = 0.0;
};

// One perf event tried with perf_event_open on the calling thread.
struct EventProbe {
  std::string name;  // rosguard's name (hw/pmc_source/perf_events.h)
  bool opens = false;
  std::string detail;  // what it counts here, or why it did not open
};

// The reference bandwidth of the host: bandwidth_read alone on one CPU (Eq. 1 MB/s = MiB/s).
struct ReferenceRun {
  double mbps = 0.0;             // median of run_mbps
  std::vector<double> run_mbps;  // every measured run
  int cpu = -1;
  bool pinned = true;  // false: the affinity could not be set, the run floated
  double working_set_kb = 0.0;
  std::uint64_t passes = 0;  // per run
  double wall_ms = 0.0;      // the whole measurement, warm-up included
};

struct HostProbe {
  std::string hostname, kernel, arch, cpu_model;
  std::string date;  // ISO 8601 UTC, when the probe ran
  int online_cpus = 0;
  std::vector<int> usable_cpus;
  std::vector<CpuCluster> clusters;  // ordered by their first usable CPU
  // Per core (of the first usable CPU); 0 when not reported.
  double l1d_kb = 0.0, l1i_kb = 0.0, l2_kb = 0.0, l3_kb_per_cluster = 0.0;
  int line_bytes = 64;
  std::string cache_source;  // where the cache facts come from
  double freq_mhz = 0.0;
  std::string freq_source;
  std::vector<EventProbe> hardware_events;  // the named hardware events of this architecture
  std::vector<EventProbe> software_events;
  bool sched_fifo = false;
  std::string sched_fifo_detail;
  std::optional<ReferenceRun> reference;  // measured only when asked
  std::vector<std::string> notes;         // what is missing, unequal or not usable
};

struct ProbeOptions {
  // Measure the reference bandwidth (bandwidth_read, 2048 KB, a few hundred ms). Not needed
  // when an installed host model provides it.
  bool measure_reference = true;
};

HostProbe probe_host(const ProbeOptions& options = {});

// The probe as JSON (the manifest's record of it, and `platform probe`'s stderr-free detail).
nlohmann::json to_json(const HostProbe& probe);

// A calibrated model of this host (rosguard calibrate --install): its document and its file.
struct InstalledModel {
  nlohmann::json doc;
  std::string path;
};

// The platform document of the probed host, named "host": cpu, caches and pmu from the probe;
// reference, memory and costs from `installed` when given (the calibrated model of this host),
// else the reference measured by the probe and no memory / costs sections (the sim backend
// cannot run it). Every section's "source" says where its numbers come from. Throws
// ContractError when neither `installed` nor probe.reference is there.
nlohmann::json host_platform_document(const HostProbe& probe,
                                      const std::optional<InstalledModel>& installed);

// The probe as the calibration suite records it. Clusters with unequal usable CPUs: the
// smallest count (what every cluster offers); no cache information: one cluster.
calibration::HostFacts host_facts(const HostProbe& probe);

}  // namespace rosguard::hw

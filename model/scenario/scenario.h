// Typed, validated scenarios: what both backends run.
//
// Contract: Scenario objects are built by the loader (tools/rosguard/load/loader.h) from documents
// that already passed their JSON Schema and carry every default; build_scenario() adds the
// checks a schema cannot express (cores that exist, one application node per core, sampling
// period <= regulation period, ...). Immutable once built; safe to share between threads.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/shared_json.h"
#include "core/types.h"
#include "metric/metric.h"

namespace rosguard {

// The common part of a platform document; backends read their own sections from `doc`.
struct PlatformInfo {
  std::string name;
  std::string origin;  // file it was loaded from
  int clusters = 1;
  int cores_per_cluster = 1;
  double freq_mhz = 0.0;
  std::uint32_t line_bytes = 64;
  double reference_mbps = 0.0;
  std::vector<std::string> pmu_events;
  unsigned counter_bits = 64;
  SharedJson doc;  // shared by every point that uses the platform

  int cores() const { return clusters * cores_per_cluster; }
  int cluster_of(int core) const { return core / cores_per_cluster; }
};

struct WorkloadInfo {
  std::string name;
  std::string origin;  // file it was loaded from, or "inline"
  // The workload document, or {"command": [...]} for an external program; shared by every
  // point that uses the workload.
  SharedJson doc;

  bool is_command() const { return doc.contains("command"); }
};

enum class NrtMode : std::uint8_t { Loop, Once };
enum class PmcSourceKind : std::uint8_t { Auto, Perf, Software, Instrumented };
enum class SchedulerKind : std::uint8_t { Fifo, Other };
// How the hw backend holds a throttled nRT core (hw/throttle/throttle.h).
enum class ThrottleMode : std::uint8_t { Auto, Fifo, Idle, Freezer };
enum class TransportKind : std::uint8_t { Inproc, Dds };
// Where an RT node's job start / stop comes from: its own jobs here, or a topic (another process).
enum class RtSignal : std::uint8_t { Self, Topic };

struct RtNodeSpec {
  std::string name;
  int core = 0;
  WorkloadInfo workload;
  int iterations = 1;
  std::optional<std::int64_t> period_us;  // absent: jobs back to back
  RtSignal signal = RtSignal::Self;
  // The job period in ns (absent: jobs back to back), converted here only.
  std::optional<TimeNs> period_ns() const {
    return period_us ? std::optional<TimeNs>(*period_us * kNsPerUs) : std::nullopt;
  }
};

struct NrtNodeSpec {
  std::string name;
  int core = 0;
  WorkloadInfo workload;
  NrtMode mode = NrtMode::Loop;
};

struct NodesSpec {
  int controller_core = 0;
  std::vector<RtNodeSpec> rt;
  std::vector<NrtNodeSpec> nrt;
};

struct RegulationSpec {
  std::string policy = "interval";
  Sampling sampling = Sampling::Self;
  std::int64_t sampling_period_us = 1000;
  std::int64_t regulation_period_us = 5000;
  double threshold_pct = 20.0;
  double reference_mbps = 0.0;  // explicit, or the platform's
  bool reference_from_platform = true;
  Scope scope = Scope::Core;
  MetricSpec metric;
  // Absolute budgets in MB/s of Eq. 1 (regulation.budget_mbps): empty: threshold_pct % of the
  // reference; one value: for every nRT node; otherwise one per nRT node, in nodes.nrt order.
  // Where given they replace threshold_pct x reference_mbps (threshold_pct is then unused).
  std::vector<double> budget_mbps;
  // Per metric event, in the metric's order (+inf: not budgeted); empty: none
  // (regulation.event_budget_mbps).
  std::vector<double> event_budget_mbps;
  double global_budget_mbps = 0.0;  // MemPol's global cap; 0: none
  bool reclaim = false;             // MemGuard
  Sharing sharing = Sharing::Off;   // MemGuard
  // Keys this point did not set that its policy's defaults filled in ("sampling = overflow
  // (memguard's default)"), for check and the manifest.
  std::vector<std::string> policy_defaults;
};

struct SimSettings {
  double quantum_us = 10.0;
};

// DDS Security files of a hw run (hw.dds.security), as written in the scenario.
struct DdsSecurityFiles {
  std::string identity_ca, identity_certificate, private_key, permissions_ca, governance,
      permissions;
};

struct HwSettings {
  PmcSourceKind pmc_source = PmcSourceKind::Auto;
  SchedulerKind scheduler = SchedulerKind::Fifo;
  ThrottleMode throttle = ThrottleMode::Auto;
  std::int64_t watchdog_ms = 100;
  // Measurements of each isolation baseline (hw.baseline_repetitions; absent: the larger of
  // repetitions and 3).
  int baseline_repetitions = 3;
  // Adjacent baselines (hw.adjacent_baselines): every point has baselines of its own, measured
  // once per repetition right before that repetition's co-run, and each repetition's slowdowns
  // divide by those (a VM's vCPUs change speed over seconds: docs/design.md, section 5).
  bool adjacent_baselines = false;
  // Adaptive repetitions (hw.precision_pct): repeat rounds of baselines and co-runs until the 95 %
  // CI of every slowdown is within this many percent of it, or max_repetitions rounds ran
  // (model/results/precision.h). Absent: exactly `repetitions` rounds.
  std::optional<double> precision_pct;
  int max_repetitions = 20;
  // A point with no progress (no RT job start or end, no finished nRT run, no signal taken) for
  // this long fails (hw.progress_timeout_ms).
  std::int64_t progress_timeout_ms = 60000;
  TransportKind transport = TransportKind::Inproc;
  std::optional<std::uint32_t> dds_domain_id;  // absent: ROS_DOMAIN_ID, else 0
  std::string dds_namespace;                   // "" or "/a[/b]"
  std::int64_t signal_timeout_ms = 60000;
  std::optional<DdsSecurityFiles> dds_security;
};

struct Scenario {
  std::string name;
  std::string description;
  std::string file;  // scenario file, for messages
  std::string backend = "sim";
  std::uint64_t seed = 1;
  int repetitions = 1;
  PlatformInfo platform;
  NodesSpec nodes;
  RegulationSpec regulation;
  SimSettings sim;
  HwSettings hw;
  nlohmann::json document;  // this point's document: defaults applied, sweep values substituted
};

// References a scenario document makes, resolved by the loader: the platform and the workload of
// every node, in document order (rt nodes first, then nrt nodes).
struct ResolvedRefs {
  PlatformInfo platform;
  std::vector<WorkloadInfo> rt_workloads;
  std::vector<WorkloadInfo> nrt_workloads;
};

// `w` with its working set sized from `platform`'s caches where its hw section asks for it
// (hw.working_set {"cache": "l2" | "l3", "times": x}): hw.working_set_kb becomes round(x x
// caches.l2_kb or caches.l3_kb_per_cluster) KB; any other workload is returned as it is.
// `file` and `pointer` name the workload's hw.working_set in errors (its file, or the scenario
// at an inline workload). Throws InputError when the platform reports no size for that cache
// or the result is outside the 4 KB .. 16777216 KB of working_set_kb.
WorkloadInfo size_working_set(const WorkloadInfo& w, const PlatformInfo& platform,
                              const std::string& file, const std::string& pointer);

// Typed view of a validated platform document. Throws InputError naming `file` and the path.
PlatformInfo build_platform(const nlohmann::json& doc, const std::string& file);

// The typed regulation of a validated document's "regulation" object (defaults applied): the
// reference from `platform` where the object has none, metric events checked against the
// platform's, budgets per nRT node by `nodes`' names. Used for scenarios and for the guard's
// configuration (the loader gives it the guard's sampling and metric).
RegulationSpec build_regulation(const nlohmann::json& regulation, const PlatformInfo& platform,
                                const NodesSpec& nodes, const std::string& file);

// Typed view of a validated scenario document with its references resolved. Throws InputError
// (file + JSON path) when the combination is inconsistent.
Scenario build_scenario(const nlohmann::json& doc, ResolvedRefs refs, const std::string& file);

// A lower bound of the simulated time one run of a point takes, in seconds: the RT nodes' jobs
// (or their periods) back to back, or without RT nodes the nRT nodes' single runs, each phase
// at its base IPC (no contention, no isolation runs). nullopt when a workload has no sim profile.
std::optional<double> min_simulated_seconds(const Scenario& s);

std::string_view to_string(NrtMode m);
std::string_view to_string(PmcSourceKind k);
std::string_view to_string(SchedulerKind k);
std::string_view to_string(ThrottleMode m);
ThrottleMode parse_throttle_mode(const std::string& s);  // a schema-validated name
std::string_view to_string(TransportKind k);
std::string_view to_string(RtSignal s);

}  // namespace rosguard

// The sim backend's typed view of a platform document: CPU, caches, the memory model and the
// middleware / OS cost distributions (scenarios/schema/platform.schema.json, "memory" and
// "costs").
//
// Contract: pure C++ (no SystemC). parse_sim_platform() reads a platform that already passed its
// JSON Schema; it throws InputError naming the platform file and the JSON path for what the
// schema cannot check (a missing section the sim needs, a median below its minimum, ...).
// Immutable once built.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "scenario/scenario.h"

namespace rosguard::sim {

// One cost distribution, in microseconds (see the "distribution" definition in the schema).
struct Distribution {
  enum class Kind : std::uint8_t { Constant, Uniform, Normal, Lognormal };
  Kind kind = Kind::Constant;
  double value_us = 0.0;       // constant
  double mean_us = 0.0;        // normal: mean; lognormal: median
  double spread = 0.0;         // normal: sd (us); lognormal: sigma
  double min_us = 0.0;         // uniform / truncation / lognormal location
  double max_us = -1.0;        // uniform / truncation / clip; < 0: none
  double mean() const;         // approximate mean (for checks and messages)
  double upper_bound() const;  // max_us when bounded, else a far tail quantile
};

struct L3Params {
  double capacity_kb = 2048.0;
  double latency_ns = 20.0;
  double queue_ns = 8.0;
  double bandwidth_mbps = 60000.0;
  bool exclusive_of_l2 = false;  // filled by the L2s' victims (platform "exclusive_of_l2")
};

struct DramParams {
  double latency_ns = 95.0;
  double queue_ns = 25.0;
  double bandwidth_mbps = 90000.0;
  // A write-back's share of the DRAM's bandwidth relative to a refill's (platform
  // "writeback_weight"; 1: a line each way).
  double writeback_weight = 1.0;
};

// A system-level cache shared by all clusters below their L3s (the platform's optional
// "memory.slc"): fed by the L3 misses, shared as an LRU cache like the L3; a hit takes latency_ns
// instead of the DRAM's (no bandwidth or queueing of its own).
struct SlcParams {
  double capacity_kb = 0.0;
  double latency_ns = 0.0;
};

// Memory-level parallelism as a limit (the platform's "memory.mshr"): L2 refills in flight.
struct MshrParams {  // defaults: the schema's largest, which no workload reaches
  double per_core = 1024.0;
  double per_cluster = 4096.0;
};

struct CoreParams {
  double callback_ipc = 1.0;
  double idle_loop_ipc = 1.0;
};

// How one built-in hw kernel (hw/workload/kernels.cpp: "bandwidth_read", "bandwidth_write",
// "latency") runs on this platform (the platform's optional "kernels" object). A workload whose
// hw.kernel has a model here runs in sim from its hw section (kernel_profile() in
// workload/profile.h) instead of its hand-written "sim" section. Times are per 64-byte line
// touched (the kernels' stride).
struct KernelModel {
  double ns_per_line_l2 = 1.0;  // working set within the private L2: core-bound
  double ns_per_line_l3 = 1.0;  // within the L3, unloaded: the base time of a line the L2 refills
  double mlp = 1.0;             // L3 misses in flight (the latency kernel's pointer chase: 1)
};

struct CostParams {
  Distribution pmc_callback;
  Distribution publish;
  Distribution message_latency;                       // between two cores
  std::optional<Distribution> local_message_latency;  // within one core, when the platform says
  // The latency of a message from a node on core `from` to one on core `to`.
  const Distribution& message_latency_between(int from, int to) const {
    return from == to && local_message_latency ? *local_message_latency : message_latency;
  }
  Distribution controller_callback;  // woken from another core (a message from there)
  // Woken on its own core (its timers, a message from a node beside it), when the platform says:
  // the callback from the controller awake to the core handed back, its commands published; a
  // command to a node on its core is then taken as the callback ends (no message latency).
  std::optional<Distribution> controller_callback_local;
  Distribution throttle_activation;
  Distribution external_read;
  // Optional: the core time of a timer-driven wake-up (interrupt, switch in and out) on a busy
  // core, charged before each timer-driven callback (a PMC sample, the controller's reads and
  // period boundaries); none without it.
  std::optional<Distribution> timer_wakeup;
  // Optional: what a workload loses to each preemption by a callback on its core beyond the
  // callback's own time (the interrupted stream starts again: its prefetches and lines in flight
  // are gone), charged as the workload's restart after the callback; none without it. rosguard
  // calibrate measures it on a memory stream beside an empty timer wake-up.
  std::optional<Distribution> preemption;
  // Optional (a platform without them refuses the sampling mode that needs them):
  // overflow sampling: from a PMU counter overflow to the throttle taking hold on that core (the
  // interrupt and its handler, MemGuard), and from a period boundary to a core's replenish;
  std::optional<Distribution> overflow_irq;
  // mmio sampling: one poll of one core by the controller core through memory-mapped debug
  // registers (read its counters, compare, and halt it when over budget: MemPol).
  std::optional<Distribution> mmio_poll;
};

struct SimPlatform {
  std::string name;
  std::string origin;
  int clusters = 1;
  int cores_per_cluster = 1;
  double freq_mhz = 1000.0;
  std::uint32_t line_bytes = 64;
  std::vector<std::string> pmu_events;
  L3Params l3;
  DramParams dram;
  std::optional<SlcParams> slc;  // none: the L3 misses go to the DRAM
  MshrParams mshr;
  CoreParams core;
  CostParams costs;
  double l2_kb = 0.0;                          // private L2 per core (kernel models)
  std::map<std::string, KernelModel> kernels;  // by hw kernel name; empty: none

  int cores() const { return clusters * cores_per_cluster; }
  int cluster_of(int core_id) const { return core_id / cores_per_cluster; }
  double freq_ghz() const { return freq_mhz / 1000.0; }  // cycles per ns
};

// The PMU events the simulated core counts (sim/platform/pmu.h); a platform may list a subset.
const std::vector<std::string>& sim_pmu_events();

// Throws InputError(platform.origin, path, message) when the platform lacks what sim needs.
SimPlatform parse_sim_platform(const PlatformInfo& platform);

}  // namespace rosguard::sim

// Workload profiles of the sim backend (the "sim" object of a workload document) and the
// progress of one run through them.
//
// A run retires `instructions` instructions. The phases, each a share of them, follow one another
// `repeat` times (segment s runs phase s % phases.size() for fraction / repeat of the run). A
// phase's L2 misses (refills, write-backs per kilo-instruction) go to the cluster's L3; its
// miss-ratio curve (mrc) says which fraction of the refills miss there for each share of the L3
// it holds (the shared-LRU model, model/cache/shared_lru.h). base_ipc is the IPC the phase would
// reach if every L2 refill were served at the unloaded L3 latency; the memory model slows it
// down as the miss latency grows (sim/platform/contention.h).
//
// Every phase has a curve, one mechanism for all (derived_mrc()):
//   - measured: the phase's "mrc" (rosguard profile: Mattson stack distances of its L2 misses);
//   - a built-in kernel (hw.kernel bandwidth_read / bandwidth_write / latency: one access per
//     line, cyclically over working_set_kb W, so every reuse has LRU stack distance W): a step at
//     kernel_reuse_kb(W) (W, or W - l2_kb where the L3 is exclusive of the L2, which then holds
//     the most recent l2_kb of the stream); the level on the L3 capacity's side of the step is the
//     profile's isolation miss ratio 1 - l3_hit, the other side LRU's (1 below, 0 from it on);
//   - otherwise (footprint_kb F, l3_hit h): MissRatioCurve::uniform_reuse(F, h, L3 capacity),
//     reuse distances spread uniformly up to the footprint.
// The derived curves keep the isolation hit ratio at the L3's capacity: l3_hit, as before.
//
// Contract: pure C++. parse_profile() reads a document that passed the workload schema (defaults
// applied) and throws InputError(file, path, message) for what the schema cannot check.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "cache/shared_lru.h"
#include "platform/sim_platform.h"
#include "scenario/scenario.h"

namespace rosguard::sim {

struct Phase {
  double fraction = 1.0;
  double base_ipc = 1.0;
  double refill_pki = 0.0;
  double wb_pki = 0.0;
  double mlp = 1.0;
  cache::MissRatioCurve mrc;  // of its L2 refills vs the L3 share it holds
};

struct WorkloadProfile {
  std::string name;
  double instructions = 0.0;
  double footprint_kb = 0.0;
  double l3_hit = 1.0;
  int repeat = 1;
  std::vector<Phase> phases;

  std::size_t segments() const { return phases.size() * static_cast<std::size_t>(repeat); }
  std::size_t phase_index(std::size_t segment) const { return segment % phases.size(); }
  double segment_instructions(std::size_t segment) const {
    return instructions * phases[phase_index(segment)].fraction / repeat;
  }
};

// `file` and `base` name the document in errors: a workload file and "/sim", or a scenario file
// and "/nodes/rt/0/workload/sim" for an inline workload. The platform gives the L3 capacity the
// derived curves keep l3_hit at.
WorkloadProfile parse_profile(const WorkloadInfo& workload, const SimPlatform& platform,
                              const std::string& file, const std::string& base);

// The L3 share a cyclic stream over `working_set_kb` needs to hit: the working set, less the
// L2 where the L3 is exclusive of it (platform memory.l3.exclusive_of_l2).
double kernel_reuse_kb(double working_set_kb, const SimPlatform& platform);

// The curve of a phase without a measured one (see above): a step at
// kernel_reuse_kb(kernel_working_set_kb) when the workload is a built-in cyclic kernel (> 0),
// else uniform reuse up to the footprint.
cache::MissRatioCurve derived_mrc(double kernel_working_set_kb, double footprint_kb, double l3_hit,
                                  const SimPlatform& platform);

// Bytes between two accesses of the built-in kernels (hw/workload/kernels.cpp): one 64-byte line.
inline constexpr double kKernelLineBytes = 64.0;

// The profile of built-in kernel `kernel` ("bandwidth_read", "bandwidth_write", "latency") over
// `working_set_kb`, `passes` times, on `platform`, from its model there:
//   - one "instruction" per line touched: the IPC columns then count lines per cycle, and
//     inst_retired lines, so ns per line = 1 / (IPC x f);
//   - within the L2 (working set <= l2_kb): base_ipc = 1 / (ns_per_line_l2 x f), no L2 misses;
//   - beyond it: a share l2_hit of the lines hits in the L2, the rest are L2 refills
//     (l2_refill_pki 1000 x (1 - l2_hit)) and, for bandwidth_write, write-backs too (the line is
//     dirty); base_ipc = 1 / ((l2_hit x ns_per_line_l2 + (1 - l2_hit) x ns_per_line_l3) x f).
//     l2_hit = 0 for the streams (a cyclic sequential pass through an LRU-like cache larger than
//     the cache misses on every line), l2_kb / working set for latency: its chase visits every
//     line equally often in a random order that the L2's replacement cannot exploit, so the L2
//     holds l2_kb of the lines and that share of the loads hits (uniform reuse). Measured: the
//     chase over 2 and 4 x the L2 of the AMD EPYC VM (2026-11-28) took 14.4 and 19.3 ns per
//     line, 5.4 ns within the L2: both fit one L3 time of 23.5 ns with hits of 1/2 and 1/4. The
//     eight calibrations in tests/sim/fixtures/measured (both vendors) each fit with a lower RMS
//     residual than with l2_hit = 0, 1.0-3.9 x lower (2026-11-28: 9.7 % -> 2.5 %; there the
//     chase beside a DRAM stream, 144 ns measured, had been predicted at 177 with every load to
//     DRAM, and the DRAM queue bent to it under-predicted two DRAM readers side by side by 17 %).
//     Beyond the L3 the same argument would give latency L3 hits of l3 / working set; no
//     calibration here can tell (one working set beyond the L3 each, but the Xeon VM's full
//     suite, whose chase saw no L3 hits even at 4 MB: the host's other tenants), so the step
//     below stays;
//   - l3_hit = 1 when kernel_reuse_kb(working set) fits the cluster's L3, else 0 (a cyclic
//     stream through an LRU cache larger than the cache misses on every line); footprint = the
//     working set;
//     mlp from the model; the curve derived_mrc(working set, ...): a step from 1 to 0 there.
// The model's steady state then gives ns_per_line_l3 + (L3 queueing + DRAM latency) / mlp per
// L2 refill (platform/contention.h). sim/calibration/fit.h fits the models with this
// function, so the fit predicts with exactly the profile the sim runs.
WorkloadProfile kernel_profile(const std::string& name, const std::string& kernel,
                               const KernelModel& model, double working_set_kb, double passes,
                               const SimPlatform& platform);

// The profile the sim runs for `workload` on `platform`: kernel_profile() when the workload's
// hw.kernel has a model in the platform's "kernels" (its hw working_set_kb and passes), else
// parse_profile() of its "sim" section.
WorkloadProfile profile_for(const WorkloadInfo& workload, const SimPlatform& platform,
                            const std::string& file, const std::string& base);

// Progress of one run of a profile. Instructions are doubles: rates are fractional per ns.
class WorkloadRun {
 public:
  explicit WorkloadRun(const WorkloadProfile& profile) : profile_(&profile) { restart(); }

  const WorkloadProfile& profile() const { return *profile_; }
  const Phase& phase() const { return profile_->phases[profile_->phase_index(segment_)]; }
  std::size_t phase_index() const { return profile_->phase_index(segment_); }
  bool finished() const { return segment_ >= profile_->segments(); }
  double remaining_in_segment() const { return remaining_; }
  std::uint64_t runs_completed() const { return runs_completed_; }
  // Instructions retired over every run so far (completed runs plus the current one).
  double retired_total() const {
    return static_cast<double>(runs_completed_) * profile_->instructions + retired_in_run_;
  }

  // Retires `n` instructions of the current segment (at most what it has left).
  void retire(double n);
  // Moves past a finished segment; returns false when that was the run's last one (the run is
  // then counted as completed).
  bool next_segment();
  // Starts the run over (loop mode).
  void restart();

 private:
  const WorkloadProfile* profile_;
  std::size_t segment_ = 0;
  double remaining_ = 0.0;
  double retired_in_run_ = 0.0;
  std::uint64_t runs_completed_ = 0;
};

}  // namespace rosguard::sim

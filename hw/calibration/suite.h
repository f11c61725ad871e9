// The calibration microbenchmark suite: what `rosguard calibrate` measures on the host with the
// hw backend's own pieces (the built-in kernels, RtThread, Topic / Waker, the PMC source the hw
// backend would pick, the controller engine), as calibration::Measurements for the sim model fit.
//
// Contract:
// - run_suite() is called from one thread (the CLI's main thread); it starts and joins every
//   thread it needs, pinned to `cores`, under SCHED_FIFO where the host allows it (else the
//   executor's SCHED_OTHER fallback, reported in notes). No thread outlives the call.
// - Kernel measurements: every KernelRun is the median ns per 64-byte line of timed windows,
//   each taken while the measured kernel and its co-runners all stream (started, warmed up,
//   measured, stopped). Windows are taken until the 95 % confidence interval of that median is
//   within the shape's precision, or up to its cap (RepetitionRule, repetitions_done()); the
//   half-width reached is the run's ci95_pct. Rounds are interleaved over the configurations of
//   one block (round r of every unfinished configuration before round r + 1 of any), so drift
//   hits them all alike.
// - Contention probes (calibration::ContentionProbe) before the first co-run block and after each:
//   a co-run block is taken again (at most kStateAttempts times in all) while a probe around it
//   is in another DRAM-interference state than the suite's so far (calibration::suite_state),
//   so that the co-runs the fit reads come from one state of a host that moves its vCPUs. Before
//   a retake the suite probes until that state is back (at most SuiteShape::state_wait_s); the
//   probes around the blocks go into the measurements, those that waited are only counted in a
//   note.
// - `stop` (set by a SIGINT handler) ends the suite between two windows: the result holds what
//   was measured so far and `stopped` is true. progress is called from the calling thread.
// - Throws RunError when the host has too little memory for a working set beyond its last-level
//   cache (shape_for), when a kernel cannot be set up (memory) or the PMC source fails.
#pragma once

#include <atomic>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "calibration/measurements.h"
#include "core/types.h"

namespace rosguard::hw {

// When a configuration has enough windows: at least `min_windows` and the 95 % confidence
// interval of their median within +-precision_pct of it, or `max_windows` rounds taken (a round
// whose window was dropped counts: the cap bounds the time).
struct RepetitionRule {
  int min_windows = 6;  // below 6 values there is no distribution-free 95 % interval of a median
  int max_windows = 20;
  double precision_pct = 4.0;
};

// Half-width of the distribution-free 95 % confidence interval of the median of `values` in % of
// the median: half the distance between the order statistics x(k) and x(n + 1 - k), k the largest
// with P(Binomial(n, 1/2) < k) <= 2.5 % (so the interval covers the median with >= 95 %, whatever
// the distribution; one stray window moves it by one rank, not by its size). +infinity for fewer
// than 6 values (no k exists) or a median <= 0.
double median_ci95_pct(std::vector<double> values);

// The stopping rule: true when `rounds` >= rule.max_windows, or `windows` holds at least
// rule.min_windows values whose median_ci95_pct() is <= rule.precision_pct.
bool repetitions_done(const std::vector<double>& windows, int rounds, const RepetitionRule& rule);

// The suite's shape: working sets, windows, window lengths, cost sample counts. shape_for()
// derives it from the host; tests pass a tiny one.
struct SuiteShape {
  std::vector<double> isolation_kb;  // isolation sweep of every kernel
  double in_l3_kb = 0.0;             // bandwidth-latency curve: measured working sets
  double dram_kb = 0.0;              // (and each co-runner's DRAM working set)
  double workload_kb = 2048.0;       // the shipped workloads' working set (co-runners, matrix)
  // Co-runner counts of the bandwidth-latency curve (each at most cores - 1); empty: every count
  // 1..cores - 1. The pair matrix always uses one.
  std::vector<int> corunner_counts;
  RepetitionRule repetitions;
  double window_ms = 20.0;         // one timed window
  double warmup_ms = 20.0;         // at most this long waiting for a kernel to stream (one pass)
  int cost_samples = 500;          // per cost
  double cost_spacing_us = 300.0;  // between two cost samples (the callee sleeps in between)
  // Before a co-run block's retake the suite probes until the DRAM-interference state of most of
  // its probes is back, at most this long over the whole suite (a probe takes about 0.6 s with
  // 20 ms windows; the quick suite about 35 s on the 2-vCPU VM, its goal is under 3 min).
  double state_wait_s = 60.0;
  std::vector<std::string> notes;  // shape_for's decisions (a DRAM set under 4x the LLC)
};

// What a shape costs on `cores` cores, worst case (every configuration to its cap), from the plan
// alone: windows x (window_ms + warmup_ms + kWindowOverheadMs), the first touch of every buffer at
// kFirstTouchMBps (co-runner buffers are built in parallel on their cores, but counted as if one
// after another), the latency kernels' chase at kChaseNsPerLine and the cost blocks'
// samples x spacing. The suite is usually faster (configurations stop at their precision).
struct SuitePlan {
  int configurations = 0;   // kernel runs it will record (isolation and co-runs)
  int max_windows = 0;      // timed windows at most (configurations x rounds cap)
  double touched_mb = 0.0;  // buffers first-touched over the whole suite
  double peak_mb = 0.0;     // buffers held at once (the measuring core's + the co-runners')
  double seconds = 0.0;     // the estimate, worst case
};
inline constexpr double kWindowOverheadMs = 2.0;  // threads started, pinned, stopped per window
// Measured on the development VM (2026-11-26): mmap + memset of a fresh 1.2 GB set 820 MB/s on
// one thread, the chase of its 19.7 M lines 80-84 ns per line.
inline constexpr double kFirstTouchMBps = 800.0;
inline constexpr double kChaseNsPerLine = 100.0;  // Sattolo's shuffle: a cache miss per line
SuitePlan plan_suite(const SuiteShape& shape, int cores);

struct SuiteOptions {
  calibration::HostFacts host;
  bool quick = false;
  // Cores to use: the first measures, the others run co-runners (and the costs' far ends).
  // Empty: the first host.cores_per_cluster usable CPUs (HostFacts does not say which CPUs
  // share the L3, so this assumes they are numbered cluster by cluster).
  std::vector<int> cores;
  // After each step: a round of one configuration (its window, retakes included) or a cost
  // block. `steps` is the steps done plus the most that can remain (every unfinished
  // configuration to its cap), so it shrinks as configurations reach their precision, and grows
  // only when a co-run block is taken again (the DRAM interference changed during it).
  std::function<void(int step, int steps, const std::string& what)> progress;
  const std::atomic<bool>* stop = nullptr;  // SIGINT: stop between windows
  const SuiteShape* shape = nullptr;        // tests: instead of shape_for(host, quick, ...)
  // MemAvailable in KB, the memory the working sets must fit in (shape_for); 0: read it from
  // /proc/meminfo (read_mem_available_kb()).
  double mem_available_kb = 0.0;
  // Called once before anything is measured, with the shape's plan (the CLI prints it).
  std::function<void(const SuitePlan&)> planned;
  // The topic transport of the message costs (publish, message_latency, local_message_latency):
  // "inproc" (the futex rings) or "dds" (Cyclone DDS as hw.transport dds uses it, on the default
  // domain in a namespace of this process).
  std::string transport = "inproc";
};

struct SuiteResult {
  calibration::Measurements measurements;
  // Fallbacks and decisions the manifest should record (SCHED_FIFO refused, working sets capped,
  // the PMC source chosen, a single core).
  std::vector<std::string> notes;
  bool stopped = false;  // stop was set: measurements are partial
};

// Working sets etc. for this host, measuring on `cores` cores with `mem_available_kb` of
// MemAvailable:
// - one set below the L2 (L2 / 2), one within the LLC (max(4x L2, 2048 KB), at most LLC / 2), the
//   workloads' 2048 KB, and the DRAM set: 4x the LLC (at least 16 MB), else 3x or 2x where memory
//   is short. The suite's buffers at their peak (the measuring core's kernels at every isolation
//   set, or at the co-run sets plus one DRAM set per co-runner core: each co-runner streams its
//   own set beyond the LLC, so that it misses the LLC even alone, whatever share it gets) must fit
//   in kMemFraction of mem_available_kb (not checked when it is <= 0: unknown); when not even 2x
//   the LLC fits, throws RunError naming the memory needed and available. 2x is the least: a
//   cyclic pass over twice an LRU-like cache evicts every line before its reuse, so the run is
//   DRAM-bound; nearer the LLC's size an adaptive replacement policy keeps part of the set and
//   the run mixes LLC hits into what should be DRAM. 4x leaves margin for such policies and for
//   a guest's LLC figure that is not what it gets.
// - Co-runner counts 1, 2, 4, ... and cores - 1 (quick and full).
// - Quick: isolation only at those sets, windows of 20 ms until +-4 %; full: isolation from 16 KB
//   doubling up to the DRAM set, windows of 30 ms until +-2 %. The cap on rounds fits the worst
//   case in kQuickBudgetS / kFullBudgetS (plan_suite), within [min_windows, 30 / 100].
inline constexpr double kMemFraction = 0.5;
inline constexpr double kQuickBudgetS = 150.0;
inline constexpr double kFullBudgetS = 1000.0;
SuiteShape shape_for(const calibration::HostFacts& host, bool quick, int cores,
                     double mem_available_kb);

// MemAvailable from /proc/meminfo in KB (0 when it cannot be read).
double read_mem_available_kb();

SuiteResult run_suite(const SuiteOptions& options);

// A contention probe: kContentionRounds rounds of one window alone and one beside; a co-run
// block is taken at most kStateAttempts times in all, each retake after probing until the
// suite's state is back (SuiteShape::state_wait_s).
inline constexpr int kContentionRounds = 7;  // >= 6 for a 95 % interval of the median; odd
// Rounds whose windows were lost (a kernel off its CPU) are taken again for up to this long.
inline constexpr double kContentionPatienceS = 20.0;
inline constexpr int kStateAttempts = 3;
// A cost block whose samples could not all be timed is taken again for the shortfall, up to this
// many rounds in all (throttle_activation, timer_wakeup, controller_callback and its local twin).
inline constexpr int kCostRounds = 3;

// One contention probe now (rosguard platform contention), on cores[0] beside cores[1], with the
// quick suite's windows. Throws RunError with fewer than two usable CPUs, or when stopped.
struct ContentionOptions {
  calibration::HostFacts host;
  std::vector<int> cores;         // two CPUs; empty: the first two the suite would use
  double working_set_kb = 0.0;    // 0: the quick suite's DRAM set on this host (shape_for)
  double mem_available_kb = 0.0;  // 0: /proc/meminfo
  const std::atomic<bool>* stop = nullptr;
};
struct ContentionResult {
  calibration::ContentionProbe probe;
  std::vector<std::string> notes;  // as SuiteResult's (SCHED_FIFO refused)
};
ContentionResult measure_contention(const ContentionOptions& options);

// A spinner's gap (monotonic ns): from its last clock read before another thread took its core
// to its first one after. The cost blocks time a wake-up on a core as the gap it makes there.
struct SpinGap {
  TimeNs start = 0, end = 0;
};
// How early a timer's wake-up may take the core before the timer is due: KVM delivered it
// 0.76-1.03 us early on the Intel Xeon VM of 2026-12-06 (the guest's TSC deadline set ahead).
inline constexpr TimeNs kWakeLeadNs = 10'000;
// The gap of each wake-up, matched by its cause: for wake-up i, `caused[i]` is when it was caused
// (a sample's publish time, a timer's due time) and `woke[i]` the woken thread's first clock read
// (both ascending). Its gap is the one that holds woke[i] and began no earlier than caused[i] -
// `lead` (one that began before is another thread's: a host's preemption of the spinner, RT
// throttling). Returns the matched gaps' lengths in us; `unmatched` counts the other wake-ups.
// A wake-up's latency into a busy core does not matter: 21-37 us on the Intel Xeon VM of
// 2026-12-06, where a fixed 20 us window after the gap's start dropped good samples.
std::vector<double> gaps_at(std::span<const SpinGap> gaps, const std::vector<TimeNs>& caused,
                            const std::vector<TimeNs>& woke, TimeNs lead, std::size_t& unmatched);

}  // namespace rosguard::hw

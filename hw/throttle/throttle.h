// How an nRT core is held while its node is throttled (THR): the paper's SCHED_FIFO idle loop, or
// a fallback that still stops the nRT work where real-time scheduling is refused.
//
//   fifo     THR spins under SCHED_FIFO 40 above the work (threads SCHED_FIFO 20, commands
//            SCHED_OTHER): the kernel never runs the work while THR spins.
//   idle     the work runs under SCHED_IDLE (weight 3 against 1024 for nice 0), THR spins under
//            SCHED_OTHER above it: the work gets a sliver of the core while THR spins. Any user
//            may move its own threads to SCHED_IDLE.
//   freezer  the work's processes sit in a cgroup v2 of their own; THR writes cgroup.freeze = 1
//            and sleeps until the node leaves THR, then thaws. Needs a writable cgroup v2
//            (root, or a delegated subtree) and processes: external commands only (a built-in
//            kernel is a thread of rosguard).
//
// Contract:
// - Throttler::hold() is called on the node's THR thread (or any thread pinned to the nRT core)
//   and returns once `held()` is false; the thread that ends the throttle notifies `wake` after
//   changing what `held()` reads. It never throws; the freezer thaws before it returns, also when
//   the write of "1" failed (then it spins instead: a visible fallback is its caller's job).
// - FreezerCgroup is RAII: created empty, thawed and removed on destruction (processes still in
//   it by then are moved back to the cgroup rosguard is in). Only the engine's thread creates and
//   destroys one; freeze()/thaw() may be called from any one thread at a time.
// - measure_hold() forks a worker pinned to `core` (counting iterations into shared memory) and
//   throttles it with the mechanism on/off for `cycles` windows; it returns the fraction of its
//   nominal rate it kept while throttled. It takes about cycles x (on_ms + off_ms) + 20 ms.
#pragma once

#include <sys/types.h>

#include <atomic>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hw/executor/executor.h"
#include "hw/topic/waker.h"
#include "scenario/scenario.h"

namespace rosguard::hw {

enum class ThrottleKind { Fifo, Idle, Freezer };
std::string_view to_string(ThrottleKind k);

// Where freezer cgroups can be made: a cgroup v2 directory we may create children in (with a
// cgroup.freeze file in them), or nullopt with the reason in `why`.
std::optional<std::string> freezer_root(std::string* why);

class FreezerCgroup {
 public:
  // mkdir `<root>/<name>`; throws RunError naming the path and errno.
  FreezerCgroup(const std::string& root, const std::string& name);
  ~FreezerCgroup();
  FreezerCgroup(const FreezerCgroup&) = delete;
  FreezerCgroup& operator=(const FreezerCgroup&) = delete;

  const std::string& path() const { return path_; }
  // Moves a process (all its threads) into the cgroup; throws RunError.
  void add(pid_t pid);
  // cgroup.freeze; false (errno in `err` when given) when the write failed.
  bool freeze(int* err = nullptr);
  bool thaw();
  // Every process in the cgroup (cgroup.procs).
  std::vector<pid_t> procs() const;

 private:
  bool write_freeze(const char* v, int* err);
  std::string path_;
  std::string home_;  // cgroup.procs of the cgroup rosguard is in (for leftovers)
  int freeze_fd_ = -1;
};

class Throttler {
 public:
  virtual ~Throttler() = default;
  virtual ThrottleKind kind() const = 0;
  virtual void hold(const std::function<bool()>& held, Waker& wake) = 0;
};
// kind Freezer needs `cgroup` (kept by the caller for the throttler's lifetime).
std::unique_ptr<Throttler> make_throttler(ThrottleKind kind, FreezerCgroup* cgroup = nullptr);

// The scheduling of an nRT node's threads under a mechanism: `sched` for CFB / THR / PMC (the
// scenario's class under fifo, SCHED_OTHER with nice values otherwise); `work` for the NCT thread
// and external commands (SCHED_IDLE under idle).
struct ThrottleSched {
  SchedClass control = SchedClass::Fifo;
  SchedClass work = SchedClass::Fifo;
};
ThrottleSched throttle_sched(ThrottleKind kind, SchedClass scenario_sched);

struct HoldMeasurement {
  ThrottleKind kind = ThrottleKind::Fifo;
  // Progress rate while held (from the moment the throttle thread took the core to the release)
  // / nominal rate; NaN when it could not be measured (detail says why).
  double hold_fraction = 0.0;
  double activation_us = 0.0;  // mean command -> throttle thread holding the core
  // Mean release -> the worker's next progress (a thaw, the throttle thread leaving the core);
  // the unthrottled windows start there.
  double resume_us = 0.0;
  int windows = 0;  // throttled windows measured
  double nominal_per_us = 0.0;
  double throttled_us = 0.0, nominal_us = 0.0;
  // The worker's CPU time / wall time in the nominal windows: well below 1, something else ran
  // on the core (then the fraction says little: a contended core slows the nominal rate too).
  double nominal_cpu_share = 0.0;
  std::string detail;  // what the measurement ran under (e.g. a refused priority)
};
// Throttled windows of 20 ms: long enough that a mechanism that only weighs the scheduler (nice
// values) shows its share, which a window shorter than the fair scheduler's slice would hide.
struct HoldProbeOptions {
  int cycles = 6;
  double on_ms = 20.0, off_ms = 10.0;
  const SchedOps* ops = nullptr;  // the throttle thread's scheduling calls (tests inject refusals)
};
// Throws RunError when the mechanism cannot be set up (no freezer, fork failed).
HoldMeasurement measure_hold(ThrottleKind kind, int core, const HoldProbeOptions& opt = {});

// "idle 0.31 % (activation 12 us)", or "... not measured".
std::string describe_hold(const HoldMeasurement& m);

// A mechanism picked for a run, with why and what was measured.
struct ThrottleChoice {
  ThrottleKind kind = ThrottleKind::Fifo;
  std::string why;
  std::string fallback;  // non-empty: the reason SCHED_FIFO is not used (a visible warning)
  std::vector<HoldMeasurement> measured;
  std::optional<std::string> freezer_root;  // set when kind is Freezer
};
struct ThrottleNeeds {
  ThrottleMode mode = ThrottleMode::Auto;
  SchedClass scenario_sched = SchedClass::Fifo;
  bool commands_only = false;  // every nRT workload is an external command (freezer possible)
  int core = 0;                // where to measure
};
// Whether SCHED_FIFO can be set here (tried on a short-lived thread); the errno text otherwise.
std::optional<std::string> fifo_refused(const SchedOps& ops = system_sched_ops());
// Throws InputError-free RunError when a forced mechanism cannot be used (callers validate first
// with throttle_unavailable()).
ThrottleChoice choose_throttle(const ThrottleNeeds& needs,
                               const SchedOps& ops = system_sched_ops());
// Why a forced mechanism cannot run here (nullopt: it can).
std::optional<std::string> throttle_unavailable(ThrottleMode mode, bool commands_only);

}  // namespace rosguard::hw

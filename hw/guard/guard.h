// rosguard guard: the deployed form of the mechanism. It regulates whatever runs on the nRT cores
// of a live system while RT nodes say they are active, with the engine every run uses (the hw
// Controller around model/engine's ControllerDriver and its Regulator and policy, one throttle
// node per core: hw/nodes/nrt_node.h in its `foreign` form, CFB + THR on the core).
//
// Contract:
// - Built, started, run and shut down on one thread (the guard's main thread). start() returns
//   once every thread runs; run() serves until `stop()` is true: it drains what the controller
//   did (ControllerNote) to the GuardPublisher and the log, and rescans the cores' processes
//   every rescan period. reload() (main thread, between run() passes) swaps the policy at the
//   next window, never pausing regulation. shutdown() (also the destructor) returns every core to
//   nominal, joins every thread (none is left under SCHED_FIFO) and gives the processes back
//   their scheduling and cgroups.
// - ActivitySource: start() is given a callback it calls from ONE thread of its own (or, for
//   InprocActivity, from whoever calls signal(), one thread at a time) with what a publisher said
//   (an RT node's index and its new state) or that a publisher is gone; stop() returns once that
//   thread has stopped calling. The guard keeps the activity as state owned by the publishers
//   (model/node/activity_states.h): duplicates, unmatched ends and floods are logged with their
//   publisher and never reach the regulator; a publisher that goes away, or an activation longer
//   than GuardSettings::max_active_ns, ends what it held.
// - The log: repeated lines (the same kind of event from the same source) are written at most once
//   per kLogRepeatNs with a count of those left out, so a busy or attacked guard's log stays
//   small.
// - Crash safety: what the guard changes in other processes (SCHED_IDLE, freezer cgroups) is
//   recorded in GuardSettings::state_dir before it is changed (hw/guard/core_tasks.h); the
//   constructor first repairs what a killed guard of the same name left there, start() logs it.
// - GuardPublisher: called on the main thread only; must not block for long (it is between the
//   controller's notes and the log).
#pragma once

#include <atomic>
#include <functional>
#include <iosfwd>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "hw/guard/core_tasks.h"
#include "hw/nodes/controller.h"
#include "hw/nodes/nrt_node.h"
#include "hw/throttle/throttle.h"
#include "node/activity_states.h"
#include "policy/policy.h"
#include "regulator/setup.h"

namespace rosguard::hw {

enum class GuardSource { Auto, Perf, Cputime };

// The log writes a repeated line at most this often (GuardStats::log_suppressed counts the rest).
inline constexpr TimeNs kLogRepeatNs = 10 * kNsPerS;
// Beyond this many kinds of line, those not written for kLogRepeatNs are forgotten.
inline constexpr std::size_t kMaxLogKeys = 256;

struct GuardSettings {
  std::string name;
  std::string file;  // for messages
  int controller_core = -1;
  std::vector<std::string> rt;
  struct Nrt {
    std::string name;
    int core = 0;
  };
  std::vector<Nrt> nrt;
  // The configuration's regulation as the loader built it (regulation_setup(): policy, external
  // sampling, periods in ns, threshold, reference, scope, one entity per nRT core); the guard
  // counts with the metric of the source it chooses (choose_source), which replaces the setup's.
  RegulationSetup regulation;
  GuardSource source = GuardSource::Auto;
  ThrottleMode throttle = ThrottleMode::Auto;
  TimeNs watchdog_ns = 100 * kNsPerMs;
  TimeNs rescan_ns = 200 * kNsPerMs;
  std::size_t publish_every = 1;
  TimeNs max_active_ns = 60 * kNsPerS;  // activity.max_active_ms; <= 0: none
  // Where the guard records what it changes in other processes (<state_dir>/<name>.record), so
  // that the next guard of this name repairs what a killed one left; "" for no record.
  std::string state_dir = "/run/rosguard";
  // Processes (by /proc/<pid>/comm) whose threads not pinned to one CPU the guard pins to the nRT
  // cores they allow (pin_processes), so that they are regulated; given back at stop.
  std::vector<std::string> pin_processes;
};

// What an activity source heard: `publisher` said RT node `rt` is (in)active, or (gone) the
// publisher disappeared. `publisher` names the sender stably (a DDS writer's GUID, the named pipe,
// "in-process").
struct ActivitySignal {
  std::size_t rt = 0;
  bool active = false;
  std::string publisher;
  bool gone = false;
};

// What this host lacks for a configuration: each configured core (nRT, controller) that is not
// usable here, as (JSON pointer, message). The guard refuses to start with any; `guard --check`
// warns of them (a configuration is often checked on another machine than its own).
std::vector<std::pair<std::string, std::string>> core_problems(const GuardSettings& s);

class ActivitySource {
 public:
  using Signal = std::function<void(const ActivitySignal&)>;
  virtual ~ActivitySource() = default;
  virtual std::string describe() const = 0;
  // Who else can steer the guard through this source, a warning each (none when only this
  // host's root can).
  virtual std::vector<std::string> exposure() const { return {}; }
  virtual void start(const std::vector<std::string>& rt_names, Signal signal) = 0;
  virtual void stop() = 0;
};

// Signals given by the caller (tests; an embedding program).
class InprocActivity : public ActivitySource {
 public:
  std::string describe() const override { return "in-process calls"; }
  void start(const std::vector<std::string>&, Signal signal) override {
    signal_ = std::move(signal);
  }
  void stop() override { signal_ = {}; }
  void signal(std::size_t rt, bool active, const std::string& publisher = "in-process") {
    if (signal_) signal_({rt, active, publisher, false});
  }
  void gone(const std::string& publisher) {
    if (signal_) signal_({0, false, publisher, true});
  }

 private:
  Signal signal_;
};

struct GuardSample {
  std::string core_name;
  int core = 0;
  TimeNs t = 0;
  double bytes = 0.0;         // accounted by this sample
  double mbps = 0.0;          // since the core's previous sample
  double used_bytes = 0.0;    // in the window so far
  double budget_bytes = 0.0;  // of the window
  double counter = 0.0;       // the metric's first counter, cumulative (as read)
};
struct GuardCommandNote {
  std::string core_name;
  int core = 0;
  TimeNs t = 0;
  Command command = Command::Off;
  TimeNs cause = 0;  // the read that caused a THR (0 otherwise)
};

class GuardPublisher {
 public:
  virtual ~GuardPublisher() = default;
  virtual std::string describe() const = 0;
  virtual void sample(const GuardSample& s) = 0;  // also the budget: used / budget
  virtual void command(const GuardCommandNote& c) = 0;
  virtual void active(TimeNs t, bool active) = 0;
};

// Publishes nothing (the log still has every state change).
class NullPublisher : public GuardPublisher {
 public:
  std::string describe() const override { return "none (log only)"; }
  void sample(const GuardSample&) override {}
  void command(const GuardCommandNote&) override {}
  void active(TimeNs, bool) override {}
};

// What a guard did so far (tests, the final log line).
struct GuardStats {
  std::uint64_t activations = 0;
  std::uint64_t samples = 0;
  std::uint64_t throttles = 0;                // THR commands sent
  std::vector<std::uint64_t> core_throttles;  // THR commands per nRT core (settings order)
  std::uint64_t policy_swaps = 0;
  std::uint64_t notes_dropped = 0;
  std::uint64_t activity_ignored = 0;  // duplicate `true`s and unmatched `false`s
  std::uint64_t activity_expired = 0;  // activations ended by max_active_ns
  std::uint64_t activity_gone = 0;     // activations ended because their publisher went away
  std::uint64_t log_lines = 0, log_suppressed = 0;
  std::vector<double> last_budget_bytes;  // per core, from the latest sample
};

class Guard {
 public:
  Guard(GuardSettings settings, ActivitySource& activity, GuardPublisher& publisher,
        std::ostream& log);
  ~Guard();
  Guard(const Guard&) = delete;
  Guard& operator=(const Guard&) = delete;

  void start();
  void run(const std::function<bool()>& stop, const std::function<bool()>& reload_due = {},
           const std::function<std::optional<GuardSettings>()>& reload_settings = {});
  // One pass of run(): drain notes, rescan when due; waits at most `max_wait_ns` for notes.
  void serve(TimeNs max_wait_ns);
  // Applies a changed configuration: regulation.threshold_pct / regulation_period_us take effect
  // from the next window; any other difference is refused (returns false, logged).
  bool reload(const GuardSettings& next);
  void shutdown();

  const GuardSettings& settings() const { return s_; }
  const ThrottleChoice& throttle() const { return throttle_; }
  const std::string& source_description() const { return source_why_; }
  GuardStats stats() const;
  std::vector<NodeState> states() const;  // per nRT core now
  std::vector<SchedOutcome> outcomes() const;

 private:
  void logln(const std::string& line);
  // logln, at most once per kLogRepeatNs for the same key (the rest counted, then summed up).
  void log_limited(const std::string& key, const std::string& line);
  void flush_suppressed();
  void on_activity(const ActivitySignal& a);  // the activity source's thread
  void expire_activity();                     // main thread
  void release(const ActivityStates::Release& r, TimeNs now, const std::string& why);
  std::string repair_after_crash();
  void check_cores() const;
  void choose_source();
  void wire(const RtThread::ErrorHandler& on_error, const std::string& record);
  void drain();
  void rescan();
  struct ErrorSink;

  GuardSettings s_;
  ActivitySource& activity_source_;
  GuardPublisher& publisher_;
  std::ostream& log_;
  ThrottleChoice throttle_;
  std::string source_name_, source_why_;
  std::unique_ptr<PmcSource> perf_;
  std::vector<std::string> group_events_;

  Waker engine_waker_, notes_waker_;
  NoteRing notes_;
  // The activity state, the RT topic's publisher slot and the log lines of the activity thread
  // are shared between that thread and the main thread (expiry): activity_mutex_.
  mutable std::mutex activity_mutex_;
  ActivityStates activity_;
  std::vector<std::pair<std::string, std::string>> activity_log_;  // key, line: drain() logs
  struct Repeat {
    TimeNs last = 0;
    std::uint64_t suppressed = 0;
  };
  std::map<std::string, Repeat> repeats_;  // main thread
  InprocTopic<RtEventMsg> rt_topic_;
  InprocTopic<SampleMsg> samples_;  // unused (external sampling); the controller needs one
  std::size_t rt_pub_ = 0;
  std::vector<std::unique_ptr<Topic<ControlMsg>>> controls_;
  std::vector<std::unique_ptr<NrtRunner>> nodes_;
  std::vector<CpuTimeGroup*> cputime_;
  bool task_clock_ = false;  // cputime: perf task clocks (else schedstat)
  std::unique_ptr<Controller> controller_;
  std::unique_ptr<CoreTasks> tasks_;
  std::shared_ptr<ErrorSink> error_sink_;
  TimeNs next_rescan_ = 0;
  std::vector<TimeNs> last_sample_t_;
  std::vector<std::size_t> sample_count_;
  std::vector<NodeState> shown_state_;
  // The activation in progress: when it began and the THR count per core then (its end line
  // gives what it cost each core).
  TimeNs activation_since_ = 0;
  std::vector<std::uint64_t> activation_throttles_;
  GuardStats stats_;
  std::vector<std::string> start_log_;  // the crash repair's lines, logged by start()
  bool started_ = false, shut_ = false;
};

}  // namespace rosguard::hw

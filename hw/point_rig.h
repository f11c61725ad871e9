// The per-point rig of the hw backend: the topics, nRT / RT nodes and controller of one point,
// wired and run through the wait protocol, then measured.
//
// Contract: built, run and destroyed on the engine's thread. The destructor (and teardown())
// returns every nRT node to nominal first, then stops the RT nodes, then the controller, and joins
// every thread, on every exit path; then it closes the topics (a DDS reader's listener must not
// outlive the node's Waker it notifies). outcome() is valid after teardown().
//
// Transport (hw.transport): inproc rings, or DDS topics with ROS 2 names under
// <hw.dds.namespace>/rosguard/<node>/... on one participant of the point. An RT node with
// signal "topic" has no thread here: another process publishes its enable / disable signal, and
// the point waits (at most hw.dds.signal_timeout_ms) for its `iterations` jobs to end.
#pragma once

#include <memory>
#include <vector>

#include "backend/backend.h"
#include "hw/backend.h"
#include "hw/metric_plan.h"
#include "hw/nodes/controller.h"
#include "hw/nodes/nrt_node.h"
#include "hw/nodes/rt_node.h"
#include "hw/throttle/throttle.h"
#include "hw/topic/dds/dds.h"
#include "hw/wait.h"
#include "regulator/setup.h"

namespace rosguard::hw {

// The finest external sampling period the hw controller is run at in place of overflow / mmio
// sampling: the floor rosguard guard's schema sets for its external sampling (guard.schema.json,
// sampling_period_us minimum), below which the controller thread's reads and wake-ups take a
// shared core from its nodes.
inline constexpr TimeNs kHwFinestPollNs = 100 * kNsPerUs;

// The regulation the hw backend runs for a point: regulation_setup() of the scenario (with the
// first RT node's isolation time in `baselines` as the monolithic window), counting the metric
// the plan counts on this host (per-event budgets dropped where it counts other events), and
// sampling as this host can. Overflow sampling (memguard) arms overflow counters on the nRT
// nodes' threads (hw/pmc_source/overflow.h) where the point's PMC source gives them on this host
// (perf and software sources, probed here; the instrumented source's workload watches) and every
// nRT node runs a built-in workload;
// otherwise, and always for mmio sampling (mempol: there are no memory-mapped debug registers to
// poll), it becomes external sampling every regulation.sampling_period_us, but not faster than
// kHwFinestPollNs. `fallback` says why the sampling differs from the scenario's ("" where it
// does not).
struct HwRegulation {
  RegulationSetup setup;
  std::string fallback;
};
HwRegulation hw_regulation(const Scenario& s, const MetricPlan& plan, const PmcSource& source,
                           const PolicyRegistry& policies, const Baselines* baselines = nullptr);

class NodeMeter;

class PointRig {
 public:
  // `regulation`: hw_regulation() of the point, with the same plan and source.
  PointRig(const Scenario& s, const MetricPlan& plan, const PmcSource& source,
           const RegulationSetup& regulation, const HwOptions& options, bool trace,
           const ThrottleChoice& throttle);
  ~PointRig();
  PointRig(const PointRig&) = delete;
  PointRig& operator=(const PointRig&) = delete;

  // Starts every thread; returns their scheduling outcomes.
  std::vector<SchedOutcome> start();
  // The wait protocol: (no RT node: activate first) nRT nodes begin, loop workloads warm up, RT
  // nodes go, wait for them (and `once` nRT nodes), then for the controller to process every
  // signal; with a silent controller, for the watchdogs. Returns early when `ctx` asks to stop or
  // a node thread failed.
  void drive(RunContext& ctx);
  void teardown();
  // After teardown(): throws RunError for a failed node thread or a dropped command.
  void check_errors() const;
  PointOutcome outcome(RunContext& ctx) const;
  std::size_t nrt_count() const { return nrts_.size(); }
  // With the dds transport: what was done to the DDS receive sockets (bound to the one interface
  // of the Cyclone configuration, or why not); null with inproc.
  const dds::ReceiveBinding* dds_binding() const {
    return participant_ ? &participant_->receive_binding() : nullptr;
  }
  // After teardown(): the overflow signals the controller took (overflow sampling), and the
  // nRT nodes (their throttle entries).
  const std::vector<OverflowRecord>& overflows() const { return controller_->overflows(); }
  const NrtRunner& nrt(std::size_t i) const { return *nrts_.at(i); }

 private:
  void wire_nodes();
  bool wait_for_signals(RunContext& ctx);
  void report_external_lag(RunContext& ctx) const;
  void make_topics();
  bool external_done() const;
  std::uint64_t progress() const;
  // True (and stall_ set) once nothing progressed for hw.progress_timeout_ms.
  bool stalled();
  void signal_samples(PointOutcome& out) const;

  const Scenario& s_;
  const MetricPlan& plan_;
  const PmcSource& source_;
  const RegulationSetup reg_;
  const HwOptions& options_;
  const bool trace_;
  const ThrottleChoice& throttle_;
  const TimeNs origin_;
  Waker engine_waker_;
  ErrorBox errors_{engine_waker_};
  std::unique_ptr<dds::Participant> participant_;  // DDS transport; outlives the topics
  std::unique_ptr<Topic<RtEventMsg>> rt_topic_;
  std::unique_ptr<Topic<SampleMsg>> samples_;
  std::vector<std::unique_ptr<Topic<ControlMsg>>> controls_;
  std::uint64_t dropped_commands_ = 0;  // counted when the topics close
  std::uint64_t ignored_messages_ = 0;  // likewise: Topic::ignored()
  std::uint64_t last_progress_ = 0;
  TimeNs last_progress_t_ = 0;
  std::string stall_;             // set when the point stalled (hw.progress_timeout_ms)
  std::vector<RtRunner*> rt_of_;  // per scenario RT node: its runner, null if external
  std::vector<std::size_t> external_rt_;
  std::string signal_timeout_;  // set when an external RT node stayed silent too long
  std::size_t engine_pub_ = 0;  // the activation when there is no RT node
  std::vector<std::unique_ptr<NrtRunner>> nrts_;
  std::vector<std::unique_ptr<RtRunner>> rts_;
  std::unique_ptr<NodeMeter> meter_;
  std::unique_ptr<Controller> controller_;
  bool torn_down_ = false;
};

}  // namespace rosguard::hw

// The RT node archetype: one thread pinned to the node's core that runs `iterations` jobs (back
// to back or every period_us) and publishes the enable / disable signal around each job.
//
// Contract: built, started and shut down by the engine's thread; the job thread publishes on the
// RT topic (its own publisher slot) and notifies the engine's waker when all jobs are done or it
// failed. shutdown() (also from the destructor) aborts a built-in job and kills a command.
#pragma once

#include <atomic>
#include <memory>
#include <vector>

#include "hw/executor/executor.h"
#include "hw/nodes/messages.h"
#include "hw/topic/topic.h"
#include "hw/workload/workload.h"
#include "scenario/scenario.h"

namespace rosguard::hw {

class RtRunner {
 public:
  RtRunner(const RtNodeSpec& spec, std::size_t index, SchedClass sched, Topic<RtEventMsg>& topic,
           Waker& engine_waker, RtThread::ErrorHandler on_error, TimeNs origin, bool trace);
  ~RtRunner();
  RtRunner(const RtRunner&) = delete;
  RtRunner& operator=(const RtRunner&) = delete;

  void start();  // thread up, waiting for go()
  void go();
  void shutdown();
  bool done() const { return done_.load(std::memory_order_acquire); }
  // Enable / disable signals published so far.
  int published() const { return published_.load(std::memory_order_acquire); }

  const RtNodeSpec& spec() const { return spec_; }
  SchedOutcome outcome() const { return thread_ ? thread_->outcome() : SchedOutcome{}; }
  // Finished jobs: start to finish, and release (its period's start) to finish.
  const std::vector<double>& job_times_us() const { return jobs_us_; }
  const std::vector<double>& response_times_us() const { return responses_us_; }
  const TraceLog& trace() const { return trace_; }

 private:
  void main();

  const RtNodeSpec& spec_;
  std::size_t index_;
  SchedClass sched_;
  Topic<RtEventMsg>& topic_;
  std::size_t pub_;
  Waker& engine_waker_;
  RtThread::ErrorHandler on_error_;
  TimeNs origin_;
  std::string track_;
  std::unique_ptr<BuiltinWorkload> builtin_;
  WorkCounters work_;
  Waker waker_;
  Fd stop_fd_;
  std::atomic<bool> go_{false}, stop_{false}, done_{false};
  std::atomic<int> published_{0};
  std::vector<double> jobs_us_, responses_us_;
  TraceLog trace_;
  std::unique_ptr<RtThread> thread_;
  bool shut_ = false;
};

}  // namespace rosguard::hw

// A non-critical (nRT) node's side of ROSGuard, attached to an existing rclcpp::Node: the paper's
// CFB, THR and PMC callbacks (Sec. III-IV), each in its own callback group on its own
// single-threaded executor and thread, pinned to the node's core by priority
// CFB (commands, SCHED_FIFO 50) > THR (the idle loop, 40) > PMC (self-sampling, 30) > NCT (the
// node's own callbacks, 20). The node's own callbacks stay on the executor its owner spins; that
// thread calls enter_nominal() (or spin_nominal()) to take the NCT place on the core.
//
//   auto node = std::make_shared<rclcpp::Node>("mapper");
//   rosguard_rclcpp::NrtGuard guard(node, rosguard_rclcpp::declare_nrt_options(*node));
//   rclcpp::executors::SingleThreadedExecutor exec;
//   exec.add_node(node);
//   guard.spin_nominal(exec);
//
// Commands come on /rosguard/<name>/command (rosguard_msgs/msg/Command), samples go out on
// /rosguard/<name>/pmc (rosguard_msgs/msg/PmcSample), the topics of rosguard's hw backend and
// guard. THR is started by CFB through a zero-time timer in THR's group (the paper's), and spins
// until CFB (above it) leaves THR. The state machine, the watchdog and the throttle bookkeeping
// are rosguard's (model/engine/nrt_driver.h); the counters and the throttle mechanism are the hw
// backend's (hw/pmc_source, hw/throttle), chosen the way it chooses them.
//
// Contract:
// - Fallbacks are visible: a refused SCHED_FIFO (throttle idle), a core it cannot pin to, a PMC
//   source other than the one asked for is logged as a warning and listed by fallbacks().
// - The destructor (or stop()) returns the node to nominal, stops the three executors, joins
//   their threads and restores the NCT thread's scheduling if enter_nominal() ran on it.
// - stats() may be read after stop(); state() and counts at any time.
#pragma once

#include <rosguard/engine/nrt_driver.h>
#include <rosguard/hw/executor/executor.h>
#include <rosguard/hw/pmc_source/pmc_source.h>
#include <rosguard/hw/throttle/throttle.h>
#include <rosguard/hw/topic/waker.h>
#include <rosguard/hw/workload/work_counters.h>

#include <atomic>
#include <memory>
#include <mutex>
#include <optional>
#include <rclcpp/rclcpp.hpp>
#include <rosguard_msgs/msg/command.hpp>
#include <rosguard_msgs/msg/pmc_sample.hpp>
#include <string>
#include <thread>
#include <vector>

#include "rosguard_rclcpp/options.hpp"

namespace rosguard_rclcpp {

struct NrtGuardStats {
  std::vector<double> activation_delays_us;  // causing sample's stamp -> THR callback entered
  std::vector<double> thr_activations_us;    // CFB took the THR command -> THR callback entered
  std::vector<double> pmc_callbacks_us;      // PMC callback: counter read + publish
  std::vector<double> pmc_reads_us;          // the counter read alone
  std::vector<std::int64_t> thr_entries_ns;  // CLOCK_MONOTONIC when THR started spinning
  std::uint64_t throttles = 0;
  std::int64_t throttled_ns = 0;
  std::uint64_t watchdog_fired = 0;
  std::uint64_t commands = 0;
};

class NrtGuard {
 public:
  // `work`: the counters of the node's nominal work (rosguard_rclcpp::Workload::counters()),
  // for the instrumented source; may be null. Throws std::runtime_error when the asked PMC
  // source cannot count here, std::invalid_argument for bad options.
  NrtGuard(rclcpp::Node::SharedPtr node, NrtGuardOptions options,
           const rosguard::hw::WorkCounters* work = nullptr);
  ~NrtGuard();
  NrtGuard(const NrtGuard&) = delete;
  NrtGuard& operator=(const NrtGuard&) = delete;

  // On the thread that will run the node's own callbacks, before it spins: pins it to the core
  // below the three callbacks and opens the counters on it. Once.
  void enter_nominal();
  // enter_nominal(), then spins `executor` (which holds the node) until rclcpp shuts down or
  // stop() is called; the thread's scheduling is restored on return.
  void spin_nominal(rclcpp::Executor& executor);
  void stop();

  rosguard::NodeState state() const { return state_.load(std::memory_order_acquire); }
  const NrtGuardOptions& options() const { return opt_; }
  const std::string& pmc_source() const { return source_name_; }
  std::vector<std::string> fallbacks() const;
  std::uint64_t throttles() const { return throttles_.load(std::memory_order_acquire); }
  // The node's counter group once enter_nominal() opened it (null before): a controller in the
  // same process reads it for external sampling (Controller::set_counters).
  rosguard::hw::CounterGroup* counters() { return group_ready_.load() ? group_.get() : nullptr; }
  NrtGuardStats stats() const;

 private:
  void on_command(const rosguard_msgs::msg::Command& m);
  void apply(const rosguard::NrtEffects& fx, std::int64_t now, std::int64_t cause);
  void on_thr();
  void on_pmc(bool baseline);
  void fallback(const std::string& what);
  void start_thread(const char* suffix, int priority, rclcpp::CallbackGroup::SharedPtr group,
                    std::unique_ptr<rclcpp::executors::SingleThreadedExecutor>& exec,
                    std::unique_ptr<rosguard::hw::RtThread>& thread);

  rclcpp::Node::SharedPtr node_;
  NrtGuardOptions opt_;
  const rosguard::hw::WorkCounters* work_;
  std::string source_name_;
  std::unique_ptr<rosguard::hw::PmcSource> source_;
  std::vector<std::string> group_events_;
  std::unique_ptr<rosguard::hw::CounterGroup> group_;
  std::atomic<bool> group_ready_{false};
  rosguard::hw::ThrottleKind throttle_kind_ = rosguard::hw::ThrottleKind::Fifo;
  rosguard::hw::ThrottleSched sched_;
  std::unique_ptr<rosguard::hw::Throttler> throttler_;
  rosguard::hw::Waker thr_waker_;

  rclcpp::CallbackGroup::SharedPtr cfb_group_, thr_group_, pmc_group_;
  rclcpp::Subscription<rosguard_msgs::msg::Command>::SharedPtr command_sub_;
  rclcpp::Publisher<rosguard_msgs::msg::PmcSample>::SharedPtr sample_pub_;
  rclcpp::TimerBase::SharedPtr thr_timer_, baseline_timer_, pmc_timer_, watchdog_timer_;
  std::unique_ptr<rclcpp::executors::SingleThreadedExecutor> cfb_exec_, thr_exec_, pmc_exec_;
  std::unique_ptr<rosguard::hw::RtThread> cfb_thread_, thr_thread_, pmc_thread_;
  std::optional<rosguard::hw::ScopedSched> nct_sched_;
  rclcpp::Executor* nominal_exec_ = nullptr;

  std::atomic<rosguard::NodeState> state_{rosguard::NodeState::Off};
  std::atomic<bool> stopping_{false};
  std::atomic<std::int64_t> thr_cause_{-1};
  std::atomic<std::int64_t> thr_taken_{-1};  // when CFB took the THR command
  std::atomic<std::uint64_t> throttles_{0};
  rosguard::NrtDriver driver_;  // CFB's thread only

  mutable std::mutex fallbacks_mutex_;
  std::vector<std::string> fallbacks_;
  // Each written by one thread (CFB, THR or PMC), read after stop().
  NrtGuardStats stats_;
  std::vector<double> activation_us_, thr_us_, pmc_us_, read_us_;
  std::vector<std::int64_t> thr_entries_;
  bool stopped_ = false;
};

}  // namespace rosguard_rclcpp

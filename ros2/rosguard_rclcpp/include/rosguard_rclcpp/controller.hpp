// ROSGuard's controller as a ROS 2 node: rosguard's regulator (model/engine/controller_driver.h,
// with the policies interval, monolithic, memguard, mempol, monitor and none) on one thread of
// its own (SCHED_FIFO 60 on rosguard.core where allowed), fed by the RT nodes' Bool on
// /rosguard/<rt>/active and, with self-sampling, the nRT nodes' PmcSample on /rosguard/<nrt>/pmc;
// its commands and keep-alives go to /rosguard/<nrt>/command.
//
// Counters of another kind per nRT node are normalised here to one count of cache lines: a
// sample with the metric's events (perf, instrumented) weighs them as the metric does; one with
// the software group (hw/pmc_source: task_clock first) is a time-based budget, task_clock x
// reference_mbps, as the hw backend's software fallback (said once per node, as a warning).
//
// External sampling reads each nRT node's counters itself: with perf, the node's core
// (rosguard.nrt_cores); in one process, the group an NrtGuard opened (set_counters()).
//
// Contract: construct, then start(); stop() (or the destructor) joins the thread. Results
// (windows(), signals(), command counts) may be read after stop().
#pragma once

#include <rosguard/engine/controller_driver.h>
#include <rosguard/hw/executor/executor.h>
#include <rosguard/hw/pmc_source/pmc_source.h>
#include <rosguard/regulator/setup.h>

#include <atomic>
#include <memory>
#include <mutex>
#include <optional>
#include <rclcpp/rclcpp.hpp>
#include <rosguard_msgs/msg/command.hpp>
#include <rosguard_msgs/msg/pmc_sample.hpp>
#include <std_msgs/msg/bool.hpp>
#include <string>
#include <vector>

#include "rosguard_rclcpp/options.hpp"

namespace rosguard_rclcpp {

struct ControllerCounts {
  std::uint64_t rt_starts = 0, rt_ends = 0;  // active true / false taken
  std::uint64_t samples = 0;                 // PMC samples taken or read
  std::uint64_t thr = 0, replenish = 0, on = 0, off = 0, keepalives = 0;
  int activations = 0;
};

class Controller {
 public:
  // Throws std::invalid_argument (rosguard's message, naming the parameter) for a regulation
  // rosguard's rules refuse.
  Controller(rclcpp::Node::SharedPtr node, ControllerOptions options);
  ~Controller();
  Controller(const Controller&) = delete;
  Controller& operator=(const Controller&) = delete;

  // One process: external sampling of nRT node `entity` reads this group (before start()).
  void set_counters(std::size_t entity, rosguard::hw::CounterGroup* group);
  void start();
  void stop();

  const rosguard::RegulationSetup& setup() const { return setup_; }
  std::vector<std::string> fallbacks() const;
  ControllerCounts counts() const;
  // After stop(): each regulation window's traffic per nRT node (policies with windows).
  const std::vector<rosguard::WindowUsage>& windows() const { return driver_->windows(); }
  const rosguard::ActivationTotals& totals() const { return driver_->totals(); }
  // After stop(): the PMC samples' transit (published -> taken here), us.
  const std::vector<double>& sample_latencies_us() const { return sample_latency_us_; }
  // After stop(): each sample's callback, taken to its commands published, us.
  const std::vector<double>& sample_callbacks_us() const { return sample_callback_us_; }

 private:
  class Meter;
  void on_active(std::size_t rt, bool active);
  void on_sample(std::size_t entity, const rosguard_msgs::msg::PmcSample& m);
  void handle();
  void read_external(std::size_t entity, std::int64_t now);
  double lines_of(std::size_t entity, std::span<const rosguard::CounterValue> v);
  void run();
  void fallback(const std::string& what);

  rclcpp::Node::SharedPtr node_;
  ControllerOptions opt_;
  rosguard::RegulationSetup setup_;
  std::unique_ptr<Meter> meter_;
  std::unique_ptr<rosguard::ControllerDriver> driver_;
  rosguard::DriverOutput out_;
  rclcpp::CallbackGroup::SharedPtr group_;
  std::vector<rclcpp::Subscription<std_msgs::msg::Bool>::SharedPtr> active_subs_;
  std::vector<rclcpp::Subscription<rosguard_msgs::msg::PmcSample>::SharedPtr> sample_subs_;
  std::vector<rclcpp::Publisher<rosguard_msgs::msg::Command>::SharedPtr> command_pubs_;
  std::vector<rosguard::hw::CounterGroup*> external_;
  std::vector<std::unique_ptr<rosguard::hw::CounterGroup>> owned_groups_;
  std::vector<char> time_based_;          // per nRT node: samples are the software group
  std::vector<double> last_lines_;        // per nRT node: cumulative lines of the last sample
  std::vector<std::uint64_t> announced_;  // per nRT node: the sample kind was logged
  double bytes_per_task_ns_ = 0.0;
  std::unique_ptr<rclcpp::executors::SingleThreadedExecutor> exec_;
  std::unique_ptr<rosguard::hw::RtThread> thread_;
  std::atomic<bool> stopping_{false};
  bool stopped_ = false;

  mutable std::mutex mutex_;  // counts_ and fallbacks_ (read by other threads while running)
  ControllerCounts counts_;
  std::vector<std::string> fallbacks_;
  std::vector<double> sample_latency_us_, sample_callback_us_;
  std::int64_t active_since_ = 0;
  std::uint64_t thr_in_activation_ = 0;
};

}  // namespace rosguard_rclcpp

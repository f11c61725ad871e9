// The nRT node of the package's tests and middleware_bench: bandwidth_read over 64 MB back to
// back in its nominal callback, under an NrtGuard on `core`, its nominal thread spinning until
// stop(). Not part of the package's API (not installed).
#pragma once

#include <memory>
#include <string>
#include <thread>

#include "rosguard_rclcpp/nrt_guard.hpp"
#include "rosguard_rclcpp/workload.hpp"

namespace rosguard_rclcpp {

struct StreamNode {
  rclcpp::Node::SharedPtr node;
  Workload work{"bandwidth_read", 65536};
  std::unique_ptr<NrtGuard> guard;
  rclcpp::TimerBase::SharedPtr timer;
  rclcpp::executors::SingleThreadedExecutor exec;
  std::thread thread;

  StreamNode(const std::string& ns, int core, const std::string& pmc_source,
             rosguard::Sampling sampling = rosguard::Sampling::Self,
             std::int64_t period_us = 1000) {
    node = std::make_shared<rclcpp::Node>("stream", ns.substr(1));
    NrtGuardOptions o;
    o.ns = ns;
    o.core = core;
    o.sampling = sampling;
    o.sampling_period_us = period_us;
    o.pmc_source = pmc_source;
    guard = std::make_unique<NrtGuard>(node, o, &work.counters());
    timer = node->create_wall_timer(std::chrono::microseconds(100), [this] { work.run(); });
    exec.add_node(node);
    thread = std::thread([this] { guard->spin_nominal(exec); });
  }
  ~StreamNode() { stop(); }
  StreamNode(const StreamNode&) = delete;
  StreamNode& operator=(const StreamNode&) = delete;
  void stop() {
    work.stop();
    guard->stop();
    if (thread.joinable()) thread.join();
  }
  // Cache lines the stream touched so far.
  double lines() const {
    return static_cast<double>(work.counters().lines_read.load() +
                               work.counters().lines_written.load());
  }
};

}  // namespace rosguard_rclcpp

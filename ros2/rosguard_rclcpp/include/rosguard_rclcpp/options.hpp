// Parameters of ROSGuard's rclcpp nodes: what a YAML parameter file sets under `rosguard.`, with
// the meaning of the scenario keys of the same name (docs/scenario-reference.md).
//
// Contract: declare_*() declares the parameters on the node (defaults as below) and reads them;
// a value out of range throws std::invalid_argument naming the parameter and the value.
#pragma once

#include <rosguard/core/types.h>

#include <cstdint>
#include <rclcpp/rclcpp.hpp>
#include <string>
#include <vector>

namespace rosguard_rclcpp {

// An nRT node's: rosguard.{name, namespace, core, sampling, sampling_period_us, pmc_source,
// throttle, watchdog_ms}.
struct NrtGuardOptions {
  std::string name;  // the controller's name for it ("" = the node's name)
  std::string ns;    // topic namespace prefix ("" = none)
  int core = -1;     // the core its nominal work and the three callbacks run on (required)
  rosguard::Sampling sampling = rosguard::Sampling::Self;
  std::int64_t sampling_period_us = 1000;
  // auto | perf | instrumented | software: auto takes perf where the hardware PMU counts the
  // metric, else instrumented where the node counts its work (rosguard_rclcpp::Workload), else
  // software (a time-based budget); each fallback is a warning and an entry of fallbacks().
  std::string pmc_source = "auto";
  // fifo (the paper's: THR spins under SCHED_FIFO above the work) | idle (the work under
  // SCHED_IDLE, for hosts that refuse SCHED_FIFO) | auto (fifo where allowed, else idle).
  std::string throttle = "auto";
  std::int64_t watchdog_ms = 100;  // back to nominal when the controller is silent this long
  std::vector<std::string> events = {"l2d_cache_refill", "l2d_cache_wb"};  // the metric's
};
NrtGuardOptions declare_nrt_options(rclcpp::Node& node);

// The controller's: rosguard.{namespace, core, rt_nodes, nrt_nodes, nrt_cores, policy, sampling,
// sampling_period_us, regulation_period_us, threshold_pct, reference_mbps, budget_mbps,
// pmc_source, keepalive_ms, rt_isolation_us, events}.
struct ControllerOptions {
  std::string ns;
  int core = -1;  // -1: not pinned
  std::vector<std::string> rt_nodes, nrt_nodes;
  std::vector<std::int64_t> nrt_cores;  // external sampling with perf: the cores counted
  std::string policy = "interval";  // interval | monolithic | memguard | mempol | monitor | none
  rosguard::Sampling sampling = rosguard::Sampling::Self;
  std::int64_t sampling_period_us = 1000;
  std::int64_t regulation_period_us = 5000;
  double threshold_pct = 20.0;
  double reference_mbps = 0.0;  // the 100 % of threshold_pct (required unless budget_mbps)
  std::vector<double> budget_mbps;
  std::string pmc_source = "auto";
  std::int64_t keepalive_ms = 20;  // while an nRT node is not OFF (below its watchdog)
  // monolithic: the RT node's execution time in isolation (the window its budget covers)
  std::int64_t rt_isolation_us = 0;
  std::vector<std::string> events = {"l2d_cache_refill", "l2d_cache_wb"};
};
ControllerOptions declare_controller_options(rclcpp::Node& node);

rosguard::Sampling parse_sampling(const std::string& parameter, const std::string& value);

}  // namespace rosguard_rclcpp

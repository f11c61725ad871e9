// `rosguard calibrate`: measure this host with the hw backend's microbenchmark suite
// (hw/calibration/suite.h), fit the sim platform model to the measurements
// (sim/calibration/fit.h), and write DIR/platform.json, DIR/calibration.json and figures;
// `--install` makes the result the model `"platform": "host"` uses in sim.
#pragma once

#include <string>

#include "load/loader.h"

namespace rosguard {

struct CalibrateOptions {
  bool quick = false;    // the short suite (a few sizes, fewer repetitions)
  std::string out;       // output folder (default: results/calibration)
  bool install = false;  // also save platform.json as this host's model
  // refit the measurements of an earlier calibration.json, measure nothing (with transport
  // rclcpp: nothing but the rclcpp middleware costs)
  std::string from;
  bool quiet = false;              // no progress
  std::string name = "host";       // the fitted platform's name
  bool strict = false;             // refuse a fit with a prior-dominated parameter (else: written)
  std::string placement = "best";  // the co-runners' placement: best, probed or apart
  // The middleware costs: inproc rings or DDS (hw.transport), or rclcpp: the nodes of the ROS 2
  // package rosguard_rclcpp (docs/ros2.md), its middleware_bench --costs from a sourced workspace
  std::string transport = "inproc";
};

// Exit code 0 on success; throws InputError (bad options or --from file) or RunError (the suite
// failed, or the fit did not converge: calibration.json keeps the measurements and the reason).
int calibrate_host(const CalibrateOptions& options, Loader& loader);

}  // namespace rosguard

// `rosguard calibrate`: measure this host and fit the sim platform model (host/calibrate.h).
#include "host/calibrate.h"

#include "commands/command.h"

namespace rosguard {

CommandHandler setup_calibrate(CLI::App& sub) {
  auto options = std::make_shared<CalibrateOptions>();
  sub.add_flag("--quick", options->quick,
               "The short suite (a few working sets, fewer repetitions; minutes)");
  sub.add_option("--out", options->out,
                 "Output folder: platform.json, calibration.json, figures/ "
                 "(default: results/calibration)");
  sub.add_flag("--install", options->install,
               "Also save platform.json as this host's model, which \"platform\": "
               "\"host\" uses in sim");
  sub.add_option("--from", options->from,
                 "Refit the measurements of an earlier calibration.json (measures nothing)")
      ->check(CLI::ExistingFile);
  sub.add_option("--name", options->name, "Name of the fitted platform (default: host)");
  sub.add_flag("--quiet", options->quiet, "No progress");
  sub.add_option("--transport", options->transport,
                 "Topic transport whose message costs are measured: inproc (default), dds "
                 "(Cyclone DDS with ROS 2 names, as hw.transport dds) or rclcpp (ROS 2 nodes of "
                 "the package rosguard_rclcpp: source its workspace first, docs/ros2.md; with "
                 "--from, only these costs are measured)")
      ->check(CLI::IsMember({"inproc", "dds", "rclcpp"}));
  sub.add_flag("--strict", options->strict,
               "Refuse the fit when a parameter rests mostly on its prior (default: write "
               "the model, name such parameters with their uncertainty)");
  sub.add_option("--placement", options->placement,
                 "Where the model puts the cores beside the measured one: best (default: fit "
                 "both, keep the one that fits better), probed (the probed clusters, sharing "
                 "their L3) or apart (each core its own L3; the DRAM shared)")
      ->check(CLI::IsMember({"best", "probed", "apart"}));
  sub.footer(
      "Runs built-in kernels alone and against co-runners on this host's cores (hw backend), "
      "times the middleware and OS costs, fits the memory model and the cost distributions by "
      "non-linear least squares (Eigen), and refuses a fit that does not converge.");
  return [options](const CommandContext& c) { return calibrate_host(*options, c.loader); };
}

}  // namespace rosguard

// The example application's nRT node (docs/ros2.md): a memory stream (a rosguard kernel over
// working_set_kb, bandwidth_read by default) in its nominal timer callback, run back to back, with
// ROSGuard attached (rosguard_rclcpp::NrtGuard, parameters rosguard.*). Every 2 s it logs the
// bandwidth it streamed and how often it was throttled.
#include <cstdio>

#include "rosguard_rclcpp/nrt_guard.hpp"
#include "rosguard_rclcpp/workload.hpp"

int main(int argc, char** argv) {
  rclcpp::init(argc, argv);
  auto node = std::make_shared<rclcpp::Node>("mapper");
  const auto kernel = node->declare_parameter<std::string>("kernel", "bandwidth_read");
  const auto ws_kb = node->declare_parameter<std::int64_t>("working_set_kb", 65536);
  int rc = 0;
  try {
    rosguard_rclcpp::Workload work(kernel, static_cast<std::uint32_t>(ws_kb));
    rosguard_rclcpp::NrtGuard guard(node, rosguard_rclcpp::declare_nrt_options(*node),
                                    &work.counters());
    std::uint64_t runs = 0, last_lines = 0;
    auto nominal = node->create_wall_timer(std::chrono::milliseconds(1), [&] {
      work.run();
      ++runs;
    });
    auto report = node->create_wall_timer(std::chrono::seconds(2), [&] {
      const auto& c = work.counters();
      const std::uint64_t lines = c.lines_read.load() + c.lines_written.load();
      RCLCPP_INFO(node->get_logger(), "%lu runs, %.0f MB/s over the last 2 s, THR %lu",
                  static_cast<unsigned long>(runs),
                  static_cast<double>(lines - last_lines) * 64.0 / (1024.0 * 1024.0) / 2.0,
                  static_cast<unsigned long>(guard.throttles()));
      last_lines = lines;
    });
    rclcpp::executors::SingleThreadedExecutor exec;
    exec.add_node(node);
    guard.spin_nominal(exec);
    guard.stop();
    std::printf("{\"node\": \"%s\", \"runs\": %lu, \"throttles\": %lu}\n", node->get_name(),
                static_cast<unsigned long>(runs), static_cast<unsigned long>(guard.throttles()));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "example_nrt_node: %s\n", e.what());
    rc = 2;
  }
  rclcpp::shutdown();
  return rc;
}

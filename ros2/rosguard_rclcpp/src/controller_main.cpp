// rosguard_controller: ROSGuard's controller node (rosguard_rclcpp/controller.hpp), configured by
// ROS 2 parameters under rosguard.* (config/example.yaml, docs/ros2.md). Exit 2 on parameters
// rosguard refuses, naming the parameter.
#include <cstdio>

#include "rosguard_rclcpp/controller.hpp"

int main(int argc, char** argv) {
  rclcpp::init(argc, argv);
  auto node = std::make_shared<rclcpp::Node>("rosguard_controller");
  int rc = 0;
  try {
    rosguard_rclcpp::Controller controller(node,
                                           rosguard_rclcpp::declare_controller_options(*node));
    controller.start();
    rclcpp::spin(node);
    controller.stop();
    const auto c = controller.counts();
    RCLCPP_INFO(node->get_logger(),
                "rosguard controller: %d activation(s), %lu RT start(s) / %lu end(s), %lu "
                "sample(s), THR %lu, REPLENISH %lu",
                c.activations, static_cast<unsigned long>(c.rt_starts),
                static_cast<unsigned long>(c.rt_ends), static_cast<unsigned long>(c.samples),
                static_cast<unsigned long>(c.thr), static_cast<unsigned long>(c.replenish));
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "rosguard_controller: %s\n", e.what());
    rc = 2;
  }
  rclcpp::shutdown();
  return rc;
}

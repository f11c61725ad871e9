// The package's tests (Catch2): rclcpp is initialised once for all of them. Run by rosguard's
// ctest through tests/ros2/package.sh (its own DDS domain, loopback only).
#define CATCH_CONFIG_RUNNER
#include <catch2/catch.hpp>
#include <rclcpp/rclcpp.hpp>

int main(int argc, char** argv) {
  rclcpp::init(1, argv);  // Catch2 reads the arguments, not ROS 2
  const int rc = Catch::Session().run(argc, argv);
  rclcpp::shutdown();
  return rc;
}

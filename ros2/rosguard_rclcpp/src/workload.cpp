#include "rosguard_rclcpp/workload.hpp"

#include <rosguard/core/error.h>
#include <rosguard/hw/common/clock.h>

#include <stdexcept>

namespace rosguard_rclcpp {

Workload::Workload(const std::string& kernel, std::uint32_t working_set_kb, int passes) {
  rosguard::WorkloadInfo info;
  info.name = kernel;
  info.origin = "rosguard_rclcpp::Workload";
  info.doc = nlohmann::json{
      {"hw", {{"kernel", kernel}, {"working_set_kb", working_set_kb}, {"passes", passes}}}};
  try {
    kernel_ = rosguard::hw::make_builtin_workload(info);
  } catch (const rosguard::InputError& e) {
    throw std::invalid_argument(e.what());
  }
}

double Workload::run() {
  const auto t0 = rosguard::hw::now_ns();
  kernel_->run(stop_, counters_);
  return static_cast<double>(rosguard::hw::now_ns() - t0) / 1e9;
}

}  // namespace rosguard_rclcpp

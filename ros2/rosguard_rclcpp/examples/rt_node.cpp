// The example application's RT node (docs/ros2.md): every rosguard.job_period_ms a job streams
// over a working set (a rosguard kernel: bandwidth_read by default), announced to the controller
// with rosguard_rclcpp::RtJob, pinned to its core (rosguard.core) under SCHED_FIFO where allowed.
// Every 2 s it logs its jobs' median time; after `jobs` jobs (0: until stopped) it exits.
#include <rosguard/hw/executor/executor.h>

#include <algorithm>
#include <vector>

#include "rosguard_rclcpp/rt_job.hpp"
#include "rosguard_rclcpp/workload.hpp"

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  rclcpp::init(argc, argv);
  auto node = std::make_shared<rclcpp::Node>("camera");
  const int core = static_cast<int>(node->declare_parameter<std::int64_t>("rosguard.core", 0));
  const auto period_ms = node->declare_parameter<std::int64_t>("job_period_ms", 100);
  const auto jobs = node->declare_parameter<std::int64_t>("jobs", 0);
  const auto kernel = node->declare_parameter<std::string>("kernel", "bandwidth_read");
  const auto ws_kb = node->declare_parameter<std::int64_t>("working_set_kb", 8192);
  const auto passes = node->declare_parameter<std::int64_t>("passes", 4);

  rosguard_rclcpp::Workload work(kernel, static_cast<std::uint32_t>(ws_kb),
                                 static_cast<int>(passes));
  rosguard_rclcpp::RtJob job(*node);
  rosguard::hw::ScopedSched sched(rosguard::hw::ThreadSpec{
      "rt-node", core, rosguard::hw::SchedClass::Fifo, rosguard::hw::prio::kRt});
  if (!sched.outcome().detail.empty())
    RCLCPP_WARN(node->get_logger(), "fallback: %s", sched.outcome().detail.c_str());

  std::vector<double> times_ms, window_ms;
  auto timer = node->create_wall_timer(std::chrono::milliseconds(period_ms), [&] {
    {
      auto scope = job.scope();
      const double s = work.run();
      times_ms.push_back(s * 1e3);
      window_ms.push_back(s * 1e3);
    }
    if (jobs > 0 && static_cast<std::int64_t>(times_ms.size()) >= jobs) rclcpp::shutdown();
  });
  auto report = node->create_wall_timer(std::chrono::seconds(2), [&] {
    RCLCPP_INFO(node->get_logger(), "%zu jobs, median %.2f ms over the last 2 s (%s %ld KB x %ld)",
                times_ms.size(), median(window_ms), kernel.c_str(), static_cast<long>(ws_kb),
                static_cast<long>(passes));
    window_ms.clear();
  });
  rclcpp::spin(node);
  std::printf("{\"node\": \"%s\", \"jobs\": %zu, \"job_ms_median\": %.3f}\n", node->get_name(),
              times_ms.size(), median(times_ms));
  rclcpp::shutdown();
  return 0;
}

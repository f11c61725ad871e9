#include "rosguard_rclcpp/rt_job.hpp"

namespace rosguard_rclcpp {

std::string rosguard_topic(const std::string& ns, const std::string& name,
                           const std::string& leaf) {
  std::string prefix = ns;
  while (!prefix.empty() && prefix.back() == '/')
    prefix.pop_back();
  return prefix + "/rosguard/" + name + "/" + leaf;
}

RtJob::RtJob(rclcpp::Node& node, std::string name, const std::string& ns)
    : name_(name.empty() ? node.get_name() : std::move(name)),
      topic_(rosguard_topic(ns, name_, "active")),
      pub_(node.create_publisher<std_msgs::msg::Bool>(topic_, rclcpp::QoS(10).reliable())) {}

void RtJob::publish(bool active) {
  std_msgs::msg::Bool m;
  m.data = active;
  pub_->publish(m);
}

}  // namespace rosguard_rclcpp

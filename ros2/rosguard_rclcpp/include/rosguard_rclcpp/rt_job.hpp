// An RT (critical) node's side of ROSGuard: it tells the controller when an RT job starts and
// ends, as std_msgs/msg/Bool true / false on /rosguard/<name>/active (the topic rosguard's hw runs
// and `rosguard guard` listen to, docs/dds.md). Regulation of the nRT nodes is active in between.
//
//   rosguard_rclcpp::RtJob job(node);            // name: the node's name
//   void on_image(const Image& m) {
//     auto scope = job.scope();                  // true now, false when the scope ends
//     process(m);
//   }
//
// Contract: the publisher is created in the constructor (reliable, keep last 10); start() / end()
// may be called from any one thread at a time; a scope publishes false on every exit path.
#pragma once

#include <rclcpp/rclcpp.hpp>
#include <std_msgs/msg/bool.hpp>
#include <string>

namespace rosguard_rclcpp {

// "/rosguard/<name>/<leaf>" under namespace `ns` ("" or "/a/b").
std::string rosguard_topic(const std::string& ns, const std::string& name, const std::string& leaf);

class RtJob {
 public:
  // `name`: the RT node's name in the controller's rt_nodes ("" = the node's name); `ns`: a topic
  // namespace prefix ("" = none).
  explicit RtJob(rclcpp::Node& node, std::string name = "", const std::string& ns = "");

  void start() { publish(true); }
  void end() { publish(false); }

  class Scope {
   public:
    explicit Scope(RtJob& job) : job_(&job) { job_->start(); }
    ~Scope() {
      if (job_) job_->end();
    }
    Scope(Scope&& o) noexcept : job_(o.job_) { o.job_ = nullptr; }
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;
    Scope& operator=(Scope&&) = delete;

   private:
    RtJob* job_;
  };
  [[nodiscard]] Scope scope() { return Scope(*this); }

  const std::string& name() const { return name_; }
  const std::string& topic() const { return topic_; }

 private:
  void publish(bool active);
  std::string name_, topic_;
  rclcpp::Publisher<std_msgs::msg::Bool>::SharedPtr pub_;
};

}  // namespace rosguard_rclcpp

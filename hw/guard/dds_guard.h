// rosguard guard over DDS (hw/topic/dds_topic.h, ROS 2 names and types):
// - DdsActivity: the RT nodes' `/rosguard/<name>/active` (std_msgs/msg/Bool) from any process on
//   the domain (only the configured nodes' topics are read); one reader thread of its own is the
//   only caller of the signal callback. Each message names its writer (its DDS GUID); a writer
//   that is no longer matched (deleted, or its participant's lease expired) is reported gone.
//   QoS: ROS 2's default (reliable, keep last 10, volatile), which any ROS 2 publisher matches;
//   the guard keeps the state per writer, so a lost or repeated message cannot unbalance it.
// - DdsPublisher: per nRT core `<core name>`, on the guard's main thread:
//     /rosguard/<core name>/pmc      rosguard_msgs/msg/PmcSample: entity = the core's index in
//                                    the configuration, stamp_ns = CLOCK_MONOTONIC of the read,
//                                    count = 3, value = {the metric's first counter (cumulative),
//                                    bytes used in the regulation window so far, the window's
//                                    budget in bytes}
//     /rosguard/<core name>/command  rosguard_msgs/msg/Command: OFF / ON / THR / REPLENISH as the
//                                    controller sends them, cause_ns = the read that caused a THR
// Both take the guard's one DDS participant (which announces the guard as a ROS 2 node); it
// outlives them. Contract: built and destroyed on the guard's main thread.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "hw/guard/guard.h"
#include "hw/topic/dds_topic.h"

namespace rosguard::hw {

class DdsActivity : public ActivitySource {
 public:
  // secured: the participant runs DDS Security (for what the guard says of its exposure).
  DdsActivity(dds::Participant& participant, std::string ns, bool secured);
  ~DdsActivity() override;
  std::string describe() const override;
  std::vector<std::string> exposure() const override;
  void start(const std::vector<std::string>& rt_names, Signal signal) override;
  void stop() override;

 private:
  void main();
  std::string name_of(const dds::Endpoint& reader, dds_instance_handle_t writer);

  dds::Participant& participant_;
  bool secured_ = false;
  std::string ns_;
  std::vector<std::unique_ptr<dds::Reader<dds::BoolMsg>>> readers_;  // per RT node
  // Reader thread only: the writers heard from or matched, and their names (GUIDs).
  std::map<dds_instance_handle_t, std::string> writers_;
  Waker waker_;
  std::atomic<bool> stop_{false};
  Signal signal_;
  std::thread thread_;
  std::vector<std::string> names_;
};

class DdsPublisher : public GuardPublisher {
 public:
  DdsPublisher(dds::Participant& participant, const std::vector<std::string>& core_names,
               const std::string& ns);
  ~DdsPublisher() override;
  std::string describe() const override;
  void sample(const GuardSample& s) override;
  void command(const GuardCommandNote& c) override;
  void active(TimeNs, bool) override {}

 private:
  std::size_t index_of(const std::string& core_name) const;
  dds::Participant& participant_;
  std::vector<std::string> names_;
  std::unique_ptr<DdsTopic<SampleMsg>> samples_;
  std::unique_ptr<DdsTopic<ControlMsg>> commands_;
  std::vector<std::size_t> sample_pubs_, command_pubs_;
};

}  // namespace rosguard::hw

// The DDS transport: Topic<T> (hw/topic/topic.h) over Cyclone DDS with ROS 2 names and types
// (hw/topic/dds/dds.h), for the three message kinds between nodes:
//   RtEventMsg  <-> std_msgs/msg/Bool             on <ns>/rosguard/<rt node>/active
//   SampleMsg   <-> rosguard_msgs/msg/PmcSample   on <ns>/rosguard/<nrt node>/pmc
//   ControlMsg  <-> rosguard_msgs/msg/Command     on <ns>/rosguard/<nrt node>/command
//
// Contract (beyond Topic<T>'s):
// - A DdsTopic is built with its publisher slots in add_publisher() order, each naming the node
//   whose ROS topic that slot writes (and a key: the RT index an `active` Bool stands for; the
//   entity of a sample is in the message). Slots beyond the publishers added here are written by
//   other processes: subscribers read every slot's topic all the same (an RT node whose
//   enable / disable signal comes from outside).
// - Each publisher slot has its own DDS writer (no writer shared between threads); each
//   subscriber has one reader per slot whose listener notifies its Waker (no polling).
// - RtEventMsg::t of a received message is the writer's DDS source timestamp on this host's
//   CLOCK_MONOTONIC (the sender's publish time, also for a sender in another process);
//   RtEventMsg::writer its DDS publication handle (writer_guid() names it).
// - A slot written here (it has a publisher of this DdsTopic) is read from that writer only:
//   samples of any other writer on the same DDS topic (another process on the domain) are
//   counted (foreign()) and ignored, so no one outside the run can command its nodes or feed
//   its controller. Samples that do not decode (a command code rosguard_msgs/msg/Command does
//   not define) are counted (undecodable()) and ignored too.
#pragma once

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "hw/nodes/messages.h"
#include "hw/topic/dds/dds.h"
#include "hw/topic/topic.h"

namespace rosguard::hw {

struct DdsSlot {
  std::string node;     // the ROS topic's node token: /rosguard/<node>/...
  std::size_t key = 0;  // RtEventMsg: the RT node's index
};

// The DDS wire type of a message kind; its encoding and topic leaf are in dds_topic.cpp.
template <class T>
struct DdsWire;
template <>
struct DdsWire<RtEventMsg> {
  using type = dds::BoolMsg;
};
template <>
struct DdsWire<SampleMsg> {
  using type = dds::PmcSampleMsg;
};
template <>
struct DdsWire<ControlMsg> {
  using type = dds::CommandMsg;
};

template <class T>
class DdsTopic final : public Topic<T> {
 public:
  DdsTopic(dds::Participant& participant, std::string ns, std::vector<DdsSlot> slots);
  ~DdsTopic() override;

  std::size_t add_publisher() override;
  std::size_t subscribe(Waker& waker) override;
  bool publish(std::size_t publisher, const T& msg) override;
  bool take(std::size_t subscriber, T& msg) override;
  std::uint64_t dropped() const override { return dropped_.load(std::memory_order_relaxed); }
  std::uint64_t ignored() const override { return foreign() + undecodable(); }
  std::uint64_t foreign() const { return foreign_.load(std::memory_order_relaxed); }
  std::uint64_t undecodable() const { return undecodable_.load(std::memory_order_relaxed); }

  // The ROS 2 topic of a slot (for logs and tests).
  const std::string& ros_topic(std::size_t slot) const { return topics_.at(slot); }

 private:
  using Wire = typename DdsWire<T>::type;
  struct Subscriber {
    std::vector<std::unique_ptr<dds::Reader<Wire>>> readers;  // one per slot
    std::size_t next = 0;
  };

  dds::Participant& participant_;
  std::vector<DdsSlot> slots_;
  std::vector<std::string> topics_;
  std::vector<std::unique_ptr<dds::Writer<Wire>>> writers_;
  std::vector<dds_instance_handle_t> writer_handles_;  // by slot, of writers_
  std::vector<Subscriber> subscribers_;
  std::atomic<std::uint64_t> dropped_{0}, foreign_{0}, undecodable_{0};
};

extern template class DdsTopic<RtEventMsg>;
extern template class DdsTopic<SampleMsg>;
extern template class DdsTopic<ControlMsg>;

}  // namespace rosguard::hw

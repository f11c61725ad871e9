#include "hw/topic/dds_topic.h"

#include <algorithm>
#include <optional>

#include "core/error.h"
#include "hw/common/clock.h"

namespace rosguard::hw {

static_assert(kMaxGroupEvents == dds::kPmcSampleSlots,
              "rosguard_msgs/msg/PmcSample carries kMaxGroupEvents counters");

// How a message kind maps to its ROS 2 type and topic leaf.
template <class T>
struct DdsCodec;

template <>
struct DdsCodec<RtEventMsg> {
  using Wire = dds::BoolMsg;
  static std::string topic(std::string_view ns, std::string_view node) {
    return dds::active_topic(ns, node);
  }
  static Wire encode(const RtEventMsg& m) { return Wire{m.started}; }
  static std::optional<RtEventMsg> decode(const Wire& w, const dds::SampleOrigin& from,
                                          const DdsSlot& slot) {
    return RtEventMsg{slot.key, w.data, dds::realtime_to_monotonic_ns(from.source_realtime_ns),
                      from.writer};
  }
};

template <>
struct DdsCodec<SampleMsg> {
  using Wire = dds::PmcSampleMsg;
  static std::string topic(std::string_view ns, std::string_view node) {
    return dds::pmc_topic(ns, node);
  }
  static Wire encode(const SampleMsg& m) {
    Wire w{};
    w.entity = static_cast<std::uint32_t>(m.entity);
    w.stamp_ns = m.t_published;
    w.count = m.count;
    for (std::size_t i = 0; i < kMaxGroupEvents; ++i) {
      w.value[i] = m.counters[i].value;
      w.time_enabled_ns[i] = m.counters[i].time_enabled_ns;
      w.time_running_ns[i] = m.counters[i].time_running_ns;
    }
    return w;
  }
  static std::optional<SampleMsg> decode(const Wire& w, const dds::SampleOrigin&, const DdsSlot&) {
    SampleMsg m;
    m.entity = w.entity;
    m.t_published = w.stamp_ns;
    m.count = w.count;
    for (std::size_t i = 0; i < kMaxGroupEvents; ++i)
      m.counters[i] = {w.value[i], w.time_enabled_ns[i], w.time_running_ns[i]};
    return m;
  }
};

template <>
struct DdsCodec<ControlMsg> {
  using Wire = dds::CommandMsg;
  static std::string topic(std::string_view ns, std::string_view node) {
    return dds::command_topic(ns, node);
  }
  static Wire encode(const ControlMsg& m) {
    std::uint8_t c = dds::command::kKeepalive;
    if (m.kind == ControlMsg::Kind::Command) {
      switch (m.command) {
        case Command::Off:
          c = dds::command::kOff;
          break;
        case Command::On:
          c = dds::command::kOn;
          break;
        case Command::Thr:
          c = dds::command::kThr;
          break;
        case Command::Replenish:
          c = dds::command::kReplenish;
          break;
      }
    }
    // rosguard_msgs/msg/Command: 0 when no sample caused it (the engine's -1).
    return Wire{c, m.t_cause < 0 ? 0 : m.t_cause};
  }
  // nullopt for a code the message type does not define (counted and ignored by take()).
  static std::optional<ControlMsg> decode(const Wire& w, const dds::SampleOrigin&, const DdsSlot&) {
    ControlMsg m;
    m.t_cause = w.cause_ns > 0 ? w.cause_ns : -1;
    switch (w.command) {
      case dds::command::kOff:
        m.command = Command::Off;
        break;
      case dds::command::kOn:
        m.command = Command::On;
        break;
      case dds::command::kThr:
        m.command = Command::Thr;
        break;
      case dds::command::kReplenish:
        m.command = Command::Replenish;
        break;
      case dds::command::kKeepalive:
        m.kind = ControlMsg::Kind::Keepalive;
        m.command = Command::On;
        break;
      default:
        return std::nullopt;
    }
    return m;
  }
};

template <class T>
DdsTopic<T>::DdsTopic(dds::Participant& participant, std::string ns, std::vector<DdsSlot> slots)
    : participant_(participant), slots_(std::move(slots)) {
  for (const auto& s : slots_)
    topics_.push_back(DdsCodec<T>::topic(ns, s.node));
}

// Readers and writers go before the participant (members are destroyed in reverse order; the
// participant is not ours).
template <class T>
DdsTopic<T>::~DdsTopic() = default;

template <class T>
std::size_t DdsTopic<T>::add_publisher() {
  const std::size_t p = writers_.size();
  if (p >= slots_.size())
    throw RunError("DDS topic: more publishers than the " + std::to_string(slots_.size()) +
                   " slots it was built with");
  writers_.push_back(std::make_unique<dds::Writer<Wire>>(participant_, topics_[p]));
  writer_handles_.push_back(writers_.back()->instance_handle());
  return p;
}

template <class T>
std::size_t DdsTopic<T>::subscribe(Waker& waker) {
  Subscriber sub;
  for (const auto& t : topics_)
    sub.readers.push_back(
        std::make_unique<dds::Reader<Wire>>(participant_, t, [&waker] { waker.notify(); }));
  subscribers_.push_back(std::move(sub));
  return subscribers_.size() - 1;
}

template <class T>
bool DdsTopic<T>::publish(std::size_t publisher, const T& msg) {
  try {
    writers_.at(publisher)->write(DdsCodec<T>::encode(msg));
    return true;
  } catch (const dds::DdsError&) {
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
}

// Round robin over the slots, as InprocTopic visits its publishers. A slot written here takes
// only its own writer's samples: another writer on the same DDS topic (another process on the
// domain) is counted and ignored, as is a message that does not decode (an unknown command code).
template <class T>
bool DdsTopic<T>::take(std::size_t subscriber, T& msg) {
  Subscriber& sub = subscribers_.at(subscriber);
  const std::size_t n = sub.readers.size();
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t s = (sub.next + i) % n;
    Wire w{};
    dds::SampleOrigin from;
    while (sub.readers[s]->take(w, &from)) {
      if (s < writer_handles_.size() && from.writer != writer_handles_[s]) {
        foreign_.fetch_add(1, std::memory_order_relaxed);
        continue;
      }
      auto m = DdsCodec<T>::decode(w, from, slots_[s]);
      if (!m) {
        undecodable_.fetch_add(1, std::memory_order_relaxed);
        continue;
      }
      sub.next = (s + 1) % n;
      msg = *m;
      return true;
    }
  }
  return false;
}

template class DdsTopic<RtEventMsg>;
template class DdsTopic<SampleMsg>;
template class DdsTopic<ControlMsg>;

}  // namespace rosguard::hw

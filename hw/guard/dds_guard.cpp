#include "hw/guard/dds_guard.h"

#include <signal.h>

#include <algorithm>

#include "core/error.h"

namespace rosguard::hw {

DdsActivity::DdsActivity(std::optional<std::uint32_t> domain_id, std::string ns)
    : participant_(std::make_unique<dds::Participant>(domain_id)), ns_(std::move(ns)) {}

DdsActivity::~DdsActivity() {
  stop();
}

std::string DdsActivity::describe() const {
  std::string topics;
  for (const auto& n : names_)
    topics += (topics.empty() ? "" : ", ") + dds::active_topic(ns_, n);
  return "DDS domain " + std::to_string(participant_->domain_id()) + ": " + topics +
         " (std_msgs/msg/Bool)";
}

void DdsActivity::start(const std::vector<std::string>& rt_names, Signal signal) {
  names_ = rt_names;
  signal_ = std::move(signal);
  std::vector<DdsSlot> slots;
  for (std::size_t i = 0; i < rt_names.size(); ++i)
    slots.push_back({rt_names[i], i});
  // Every slot is written by another process: no publisher here, one subscriber (this thread).
  topic_ = std::make_unique<DdsTopic<RtEventMsg>>(*participant_, ns_, slots);
  sub_ = topic_->subscribe(waker_);
  sigset_t block, old;
  sigemptyset(&block);
  for (int sig : {SIGINT, SIGTERM, SIGHUP})
    sigaddset(&block, sig);
  ::pthread_sigmask(SIG_BLOCK, &block, &old);  // signals go to the main thread
  thread_ = std::thread([this] {
    while (!stop_.load(std::memory_order_acquire)) {
      const auto e = waker_.epoch();
      RtEventMsg m;
      bool got = false;
      while (topic_->take(sub_, m)) {
        got = true;
        if (m.rt < names_.size()) signal_(m.rt, m.started);
      }
      if (!got) waker_.wait(e, -1);
    }
  });
  ::pthread_sigmask(SIG_SETMASK, &old, nullptr);
}

void DdsActivity::stop() {
  if (!thread_.joinable()) return;
  stop_.store(true, std::memory_order_release);
  waker_.notify();
  thread_.join();
  topic_.reset();
}

DdsPublisher::DdsPublisher(const std::vector<std::string>& core_names,
                           std::optional<std::uint32_t> domain_id, std::string ns)
    : participant_(std::make_unique<dds::Participant>(domain_id)), names_(core_names) {
  std::vector<DdsSlot> slots;
  for (std::size_t i = 0; i < core_names.size(); ++i)
    slots.push_back({core_names[i], i});
  samples_ = std::make_unique<DdsTopic<SampleMsg>>(*participant_, ns, slots);
  commands_ = std::make_unique<DdsTopic<ControlMsg>>(*participant_, ns, slots);
  for (std::size_t i = 0; i < core_names.size(); ++i) {
    sample_pubs_.push_back(samples_->add_publisher());
    command_pubs_.push_back(commands_->add_publisher());
  }
}

DdsPublisher::~DdsPublisher() {
  commands_.reset();
  samples_.reset();
}

std::string DdsPublisher::describe() const {
  std::string topics;
  for (std::size_t i = 0; i < names_.size(); ++i)
    topics +=
        (topics.empty() ? "" : ", ") + samples_->ros_topic(i) + ", " + commands_->ros_topic(i);
  return "DDS domain " + std::to_string(participant_->domain_id()) + ": " + topics;
}

std::size_t DdsPublisher::index_of(const std::string& core_name) const {
  return static_cast<std::size_t>(std::find(names_.begin(), names_.end(), core_name) -
                                  names_.begin());
}

void DdsPublisher::sample(const GuardSample& s) {
  const std::size_t i = index_of(s.core_name);
  if (i >= names_.size()) return;
  SampleMsg m;
  m.entity = i;
  m.t_published = s.t;
  m.count = 3;
  m.counters[0].value = static_cast<std::uint64_t>(s.counter);
  m.counters[1].value = static_cast<std::uint64_t>(s.used_bytes);
  m.counters[2].value = static_cast<std::uint64_t>(s.budget_bytes);
  samples_->publish(sample_pubs_[i], m);
}

void DdsPublisher::command(const GuardCommandNote& c) {
  const std::size_t i = index_of(c.core_name);
  if (i >= names_.size()) return;
  commands_->publish(command_pubs_[i], {ControlMsg::Kind::Command, c.command, c.cause});
}

}  // namespace rosguard::hw

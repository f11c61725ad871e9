#include "hw/guard/dds_guard.h"

#include <signal.h>

#include <algorithm>
#include <cstdio>
#include <set>

#include "core/error.h"

namespace rosguard::hw {

DdsActivity::DdsActivity(dds::Participant& participant, std::string ns, bool secured)
    : participant_(participant), secured_(secured), ns_(std::move(ns)) {}

DdsActivity::~DdsActivity() {
  stop();
}

std::string DdsActivity::describe() const {
  std::string topics;
  for (const auto& r : readers_)
    topics += (topics.empty() ? "" : ", ") + r->ros_topic();
  const dds::ReceiveBinding& b = participant_.receive_binding();
  return "DDS domain " + std::to_string(participant_.domain_id()) +
         (secured_ ? " with DDS Security" : "") + ": " + topics + " (std_msgs/msg/Bool)" +
         (b.bound ? "; " + b.text : "");
}

std::vector<std::string> DdsActivity::exposure() const {
  std::vector<std::string> out;
  if (!secured_)
    out.push_back("any process that reaches DDS domain " +
                  std::to_string(participant_.domain_id()) +
                  " can publish the RT nodes' activity (no DDS Security): it cannot stop the "
                  "guard or unbalance its state, but it can hold regulation on (up to "
                  "activity.max_active_ms at a time) and, by flooding, crowd out an RT node's own "
                  "messages; keep the domain on a private network (CYCLONEDDS_URI)");
  if (const dds::ReceiveBinding& b = participant_.receive_binding(); !b.bound)
    out.push_back("fallback (dds binding): " + b.text);
  return out;
}

void DdsActivity::start(const std::vector<std::string>& rt_names, Signal signal) {
  names_ = rt_names;
  signal_ = std::move(signal);
  for (const auto& n : rt_names)
    readers_.push_back(std::make_unique<dds::Reader<dds::BoolMsg>>(
        participant_, dds::active_topic(ns_, n), [this] { waker_.notify(); }));
  sigset_t block, old;
  sigemptyset(&block);
  for (int sig : {SIGINT, SIGTERM, SIGHUP})
    sigaddset(&block, sig);
  ::pthread_sigmask(SIG_BLOCK, &block, &old);  // signals go to the main thread
  thread_ = std::thread([this] { main(); });
  ::pthread_sigmask(SIG_SETMASK, &old, nullptr);
}

// A writer's name: its GUID while it is matched (looked up once); a writer whose sample is taken
// after it left is named by its handle.
std::string DdsActivity::name_of(const dds::Endpoint& reader, dds_instance_handle_t writer) {
  auto it = writers_.find(writer);
  if (it != writers_.end()) return it->second;
  std::string guid = reader.writer_guid(writer);
  if (guid.empty()) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "handle %016llx", static_cast<unsigned long long>(writer));
    guid = buf;
  }
  return writers_.emplace(writer, "writer " + guid).first->second;
}

void DdsActivity::main() {
  while (!stop_.load(std::memory_order_acquire)) {
    const auto e = waker_.epoch();
    // Messages first, then who is gone: a writer's last message counts before its departure.
    for (std::size_t i = 0; i < readers_.size(); ++i) {
      dds::BoolMsg m{};
      dds::SampleOrigin from;
      while (readers_[i]->take(m, &from))
        signal_({i, m.data, name_of(*readers_[i], from.writer), false});
    }
    std::set<dds_instance_handle_t> matched;
    for (const auto& r : readers_)
      for (dds_instance_handle_t h : r->matched_writers()) {
        matched.insert(h);
        name_of(*r, h);
      }
    for (auto it = writers_.begin(); it != writers_.end();) {
      if (matched.count(it->first)) {
        ++it;
        continue;
      }
      signal_({0, false, it->second, true});
      it = writers_.erase(it);
    }
    waker_.wait(e, -1);
  }
}

void DdsActivity::stop() {
  if (!thread_.joinable()) return;
  stop_.store(true, std::memory_order_release);
  waker_.notify();
  thread_.join();
  readers_.clear();
}

DdsPublisher::DdsPublisher(dds::Participant& participant,
                           const std::vector<std::string>& core_names, const std::string& ns)
    : participant_(participant), names_(core_names) {
  std::vector<DdsSlot> slots;
  for (std::size_t i = 0; i < core_names.size(); ++i)
    slots.push_back({core_names[i], i});
  samples_ = std::make_unique<DdsTopic<SampleMsg>>(participant_, ns, slots);
  commands_ = std::make_unique<DdsTopic<ControlMsg>>(participant_, ns, slots);
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
  return "DDS domain " + std::to_string(participant_.domain_id()) + ": " + topics;
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

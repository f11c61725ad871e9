#include "rosguard_rclcpp/controller.hpp"

#include <rosguard/core/error.h>
#include <rosguard/hw/common/clock.h>
#include <rosguard/hw/nodes/messages.h>
#include <rosguard/policy/builtin_registry.h>

#include <algorithm>
#include <array>
#include <stdexcept>

#include "rosguard_rclcpp/rt_job.hpp"

namespace rosguard_rclcpp {

namespace hw = rosguard::hw;
using rosguard_msgs::msg::Command;

namespace {

constexpr std::chrono::milliseconds kIdleWait{50};  // longest wait: the thread looks at stop
constexpr double kLineBytes = 64.0;                 // the normalised metric: cache lines

std::uint8_t message_command(rosguard::Command c) {
  switch (c) {
    case rosguard::Command::On:
      return Command::ON;
    case rosguard::Command::Off:
      return Command::OFF;
    case rosguard::Command::Thr:
      return Command::THR;
    case rosguard::Command::Replenish:
      return Command::REPLENISH;
  }
  return Command::OFF;
}

}  // namespace

// The driver's accounting: each nRT node's cumulative lines, read fresh from its group where the
// controller has one (external sampling, one process), else the last sample taken.
class Controller::Meter : public rosguard::EntityMeter {
 public:
  explicit Meter(Controller& c) : c_(c) {}
  rosguard::EntityReading read(std::size_t e, rosguard::TimeNs) override {
    if (auto* g = c_.external_.at(e)) {
      std::array<rosguard::CounterValue, hw::kMaxGroupEvents> v{};
      g->read(std::span(v.data(), g->size()));
      return {c_.lines_of(e, std::span(v.data(), g->size())) * kLineBytes, 0.0, 0.0};
    }
    return {c_.last_lines_[e] * kLineBytes, 0.0, 0.0};
  }

 private:
  Controller& c_;
};

Controller::Controller(rclcpp::Node::SharedPtr node, ControllerOptions options)
    : node_(std::move(node)), opt_(std::move(options)) {
  const std::size_t nrt = opt_.nrt_nodes.size();
  rosguard::RegulationSpec r;
  r.policy = opt_.policy;
  r.sampling = opt_.sampling;
  r.sampling_period_us = opt_.sampling_period_us;
  r.regulation_period_us = opt_.regulation_period_us;
  r.threshold_pct = opt_.threshold_pct;
  r.reference_mbps = opt_.reference_mbps;
  r.reference_from_platform = false;
  r.budget_mbps = opt_.budget_mbps;
  // One normalised count per nRT node (lines_of): the regulator sees cache lines.
  r.metric.line_bytes = static_cast<std::uint32_t>(kLineBytes);
  r.metric.events = {{"lines", 1.0}};
  if (!r.budget_mbps.empty() && r.budget_mbps.size() != 1 && r.budget_mbps.size() != nrt)
    throw std::invalid_argument("parameter rosguard.budget_mbps: one value, or one per nRT node (" +
                                std::to_string(nrt) + ")");
  try {
    setup_ = rosguard::regulation_setup(r, {opt_.rt_nodes.size(), nrt},
                                        rosguard::builtin_registry(), "rosguard-parameters");
  } catch (const rosguard::InputError& e) {
    // rosguard names a scenario's JSON path; here it is the parameter of the same name.
    std::string what = e.what();
    const std::string from = "rosguard-parameters: /regulation/";
    if (auto at = what.find(from); at != std::string::npos)
      what.replace(at, from.size(), "parameter rosguard.");
    throw std::invalid_argument(what);
  }
  if (opt_.policy == "monolithic") {
    if (opt_.rt_isolation_us <= 0)
      throw std::invalid_argument(
          "parameter rosguard.rt_isolation_us: monolithic sizes its budget by the RT node's "
          "execution time in isolation; give it in us");
    setup_.params.monolithic_window_ns = opt_.rt_isolation_us * rosguard::kNsPerUs;
  }
  bytes_per_task_ns_ = opt_.reference_mbps * rosguard::kBytesPerMb / 1e9;
  external_.assign(nrt, nullptr);
  time_based_.assign(nrt, 0);
  last_lines_.assign(nrt, 0.0);
  announced_.assign(nrt, 0);

  // External sampling with a hardware PMU: each nRT core's events (rosguard.nrt_cores).
  if (opt_.sampling == rosguard::Sampling::External && opt_.pmc_source != "instrumented" &&
      opt_.pmc_source != "software") {
    auto perf = hw::make_perf_source();
    if (!perf->unavailable_reason() && opt_.nrt_cores.size() == nrt) {
      for (std::size_t e = 0; e < nrt; ++e) {
        hw::PmcTarget t;
        t.kind = hw::PmcTarget::Kind::Cpu;
        t.cpu = static_cast<int>(opt_.nrt_cores[e]);
        owned_groups_.push_back(perf->open(opt_.events, t));
        external_[e] = owned_groups_.back().get();
      }
    } else if (opt_.pmc_source == "perf") {
      throw std::invalid_argument(
          "parameter rosguard.pmc_source = perf: external sampling needs a working hardware PMU "
          "and rosguard.nrt_cores (one core per nRT node)");
    }
  }

  meter_ = std::make_unique<Meter>(*this);
  rosguard::ControllerDriverConfig cfg;
  cfg.sampling = setup_.sampling;
  cfg.sampling_period_ns = setup_.sampling_period_ns;
  cfg.keepalive_ns = opt_.keepalive_ms * rosguard::kNsPerMs;
  cfg.record_windows = true;
  driver_ =
      std::make_unique<rosguard::ControllerDriver>(cfg, setup_.make_regulator(), meter_.get());

  group_ = node_->create_callback_group(rclcpp::CallbackGroupType::MutuallyExclusive, false);
  rclcpp::SubscriptionOptions so;
  so.callback_group = group_;
  const auto qos = rclcpp::QoS(100).reliable();
  for (std::size_t i = 0; i < opt_.rt_nodes.size(); ++i)
    active_subs_.push_back(node_->create_subscription<std_msgs::msg::Bool>(
        rosguard_topic(opt_.ns, opt_.rt_nodes[i], "active"), qos,
        [this, i](const std_msgs::msg::Bool& m) { on_active(i, m.data); }, so));
  for (std::size_t e = 0; e < nrt; ++e) {
    command_pubs_.push_back(node_->create_publisher<Command>(
        rosguard_topic(opt_.ns, opt_.nrt_nodes[e], "command"), qos));
    if (opt_.sampling == rosguard::Sampling::Self)
      sample_subs_.push_back(node_->create_subscription<rosguard_msgs::msg::PmcSample>(
          rosguard_topic(opt_.ns, opt_.nrt_nodes[e], "pmc"), qos,
          [this, e](const rosguard_msgs::msg::PmcSample& m) { on_sample(e, m); }, so));
  }
  sample_latency_us_.reserve(1 << 16);
  sample_callback_us_.reserve(1 << 16);
}

Controller::~Controller() {
  stop();
}

void Controller::set_counters(std::size_t entity, hw::CounterGroup* group) {
  if (thread_) throw std::logic_error("rosguard: set_counters() after start()");
  external_.at(entity) = group;
}

void Controller::fallback(const std::string& what) {
  RCLCPP_WARN(node_->get_logger(), "rosguard controller: fallback: %s", what.c_str());
  std::lock_guard lock(mutex_);
  fallbacks_.push_back(what);
}

std::vector<std::string> Controller::fallbacks() const {
  std::lock_guard lock(mutex_);
  return fallbacks_;
}

ControllerCounts Controller::counts() const {
  std::lock_guard lock(mutex_);
  return counts_;
}

void Controller::start() {
  if (opt_.sampling == rosguard::Sampling::External)
    for (std::size_t e = 0; e < external_.size(); ++e)
      if (!external_[e])
        throw std::invalid_argument(
            "rosguard controller: external sampling of nRT node '" + opt_.nrt_nodes[e] +
            "' needs its counters: a hardware PMU (perf, rosguard.nrt_cores) or, in one process, "
            "Controller::set_counters() with the node's NrtGuard::counters()");
  exec_ = std::make_unique<rclcpp::executors::SingleThreadedExecutor>();
  exec_->add_callback_group(group_, node_->get_node_base_interface());
  hw::ThreadSpec spec{"rg-controller", opt_.core, hw::SchedClass::Fifo, hw::prio::kController};
  thread_ = std::make_unique<hw::RtThread>(
      spec, [this] { run(); },
      [this](const std::string& t, std::exception_ptr err) {
        try {
          std::rethrow_exception(err);
        } catch (const std::exception& x) {
          RCLCPP_ERROR(node_->get_logger(), "rosguard controller: thread %s failed: %s", t.c_str(),
                       x.what());
        }
      });
  const auto& o = thread_->outcome();
  if (!o.pinned || !o.fifo) fallback(o.detail);
  RCLCPP_INFO(node_->get_logger(), "rosguard controller: %s; RT nodes %zu, nRT nodes %zu",
              setup_.describe().c_str(), opt_.rt_nodes.size(), opt_.nrt_nodes.size());
}

void Controller::stop() {
  if (stopped_) return;
  stopped_ = true;
  stopping_.store(true, std::memory_order_release);
  if (exec_) exec_->cancel();
  if (thread_) thread_->join();
  // Leave no node throttled: OFF to every nRT node.
  for (auto& p : command_pubs_) {
    Command m;
    m.command = Command::OFF;
    p->publish(m);
  }
}

void Controller::run() {
  auto context = node_->get_node_base_interface()->get_context();
  while (!stopping_.load(std::memory_order_acquire) && context->is_valid()) {
    auto wait = std::chrono::nanoseconds(kIdleWait);
    if (auto next = driver_->next_wakeup())
      wait = std::clamp(std::chrono::nanoseconds(*next - hw::now_ns()), std::chrono::nanoseconds(0),
                        wait);
    exec_->spin_once(wait);
    const auto now = hw::now_ns();
    if (auto next = driver_->next_wakeup(); next && *next <= now) {
      driver_->wake(now, out_);
      handle();
    }
  }
  driver_->finish(hw::now_ns(), out_);
  out_.clear();
}

void Controller::on_active(std::size_t rt, bool active) {
  const auto now = hw::now_ns();
  {
    std::lock_guard lock(mutex_);
    ++(active ? counts_.rt_starts : counts_.rt_ends);
  }
  driver_->rt_signal(now, rt, active, out_);
  handle();
}

double Controller::lines_of(std::size_t e, std::span<const rosguard::CounterValue> v) {
  const bool software =
      v.size() == hw::software_group_events().size() && opt_.events.size() != v.size();
  if (software != static_cast<bool>(time_based_[e]) || !announced_[e]) {
    time_based_[e] = software;
    announced_[e] = 1;
    if (software)
      fallback("nRT node '" + opt_.nrt_nodes[e] +
               "' counts with the software source (no bandwidth events): its budget is time, "
               "task_clock x reference_mbps");
  }
  if (software) return static_cast<double>(v[0].value) * bytes_per_task_ns_ / kLineBytes;
  // The metric's events, weighted as rosguard's default metric (refills + write-backs).
  double lines = 0.0;
  for (std::size_t i = 0; i < v.size() && i < opt_.events.size(); ++i)
    lines += static_cast<double>(v[i].value);
  return lines;
}

void Controller::on_sample(std::size_t e, const rosguard_msgs::msg::PmcSample& m) {
  const auto now = hw::now_ns();
  const std::size_t n = std::min<std::size_t>(m.count, hw::kMaxGroupEvents);
  std::array<rosguard::CounterValue, hw::kMaxGroupEvents> v{};
  for (std::size_t i = 0; i < n; ++i)
    v[i] = {m.value[i], m.time_enabled_ns[i], m.time_running_ns[i]};
  last_lines_[e] = lines_of(e, std::span(v.data(), n));
  const rosguard::CounterValue lines{static_cast<std::uint64_t>(last_lines_[e]),
                                     v[0].time_enabled_ns, v[0].time_running_ns};
  if (sample_latency_us_.size() < sample_latency_us_.capacity())
    sample_latency_us_.push_back(hw::ns_to_us(now - m.stamp_ns));
  {
    std::lock_guard lock(mutex_);
    ++counts_.samples;
  }
  driver_->sample(now, e, std::span(&lines, 1), m.stamp_ns, out_);
  handle();
  if (sample_callback_us_.size() < sample_callback_us_.capacity())
    sample_callback_us_.push_back(hw::ns_to_us(hw::now_ns() - now));
}

void Controller::read_external(std::size_t e, std::int64_t now) {
  auto* g = external_.at(e);
  std::array<rosguard::CounterValue, hw::kMaxGroupEvents> v{};
  g->read(std::span(v.data(), g->size()));
  last_lines_[e] = lines_of(e, std::span(v.data(), g->size()));
  const rosguard::CounterValue lines{static_cast<std::uint64_t>(last_lines_[e]),
                                     v[0].time_enabled_ns, v[0].time_running_ns};
  {
    std::lock_guard lock(mutex_);
    ++counts_.samples;
  }
  driver_->sample(now, e, std::span(&lines, 1), now, out_);
}

void Controller::handle() {
  // External reads first (they may add commands), then what is to be sent.
  while (!out_.reads.empty()) {
    auto reads = std::move(out_.reads);
    out_.reads.clear();
    for (auto e : reads)
      read_external(e, hw::now_ns());
  }
  for (const auto& c : out_.commands) {
    Command m;
    m.command = message_command(c.command);
    m.cause_ns = c.cause > 0 ? c.cause : 0;
    command_pubs_.at(c.entity)->publish(m);
    std::lock_guard lock(mutex_);
    switch (c.command) {
      case rosguard::Command::Thr:
        ++counts_.thr;
        ++thr_in_activation_;
        break;
      case rosguard::Command::Replenish:
        ++counts_.replenish;
        break;
      case rosguard::Command::On:
        ++counts_.on;
        break;
      case rosguard::Command::Off:
        ++counts_.off;
        break;
    }
  }
  for (auto e : out_.keepalives) {
    Command m;
    m.command = Command::KEEPALIVE;
    command_pubs_.at(e)->publish(m);
    std::lock_guard lock(mutex_);
    ++counts_.keepalives;
  }
  for (const auto& ev : out_.events) {
    if (ev.kind == rosguard::EngineEvent::Kind::ActivationBegin) {
      active_since_ = ev.t;
      thr_in_activation_ = 0;
      std::lock_guard lock(mutex_);
      ++counts_.activations;
    } else if (ev.kind == rosguard::EngineEvent::Kind::ActivationEnd) {
      RCLCPP_INFO(node_->get_logger(),
                  "rosguard controller: activation ended after %.1f ms, THR %lu",
                  static_cast<double>(ev.t - active_since_) / 1e6,
                  static_cast<unsigned long>(thr_in_activation_));
    }
  }
  out_.clear();
}

}  // namespace rosguard_rclcpp

#include "rosguard_rclcpp/nrt_guard.hpp"

#include <rosguard/hw/common/clock.h>
#include <rosguard/hw/common/sys.h>
#include <rosguard/hw/nodes/messages.h>

#include <algorithm>
#include <array>
#include <stdexcept>

#include "rosguard_rclcpp/rt_job.hpp"

namespace rosguard_rclcpp {

namespace hw = rosguard::hw;
using rosguard::NodeState;
using rosguard_msgs::msg::Command;

namespace {

constexpr std::chrono::milliseconds kSpinSlice{50};  // how often a node thread looks at stop

// The message's command as rosguard's (KEEPALIVE is handled before).
std::optional<rosguard::Command> model_command(std::uint8_t c) {
  switch (c) {
    case Command::OFF:
      return rosguard::Command::Off;
    case Command::ON:
      return rosguard::Command::On;
    case Command::THR:
      return rosguard::Command::Thr;
    case Command::REPLENISH:
      return rosguard::Command::Replenish;
    default:
      return std::nullopt;
  }
}

std::string missing_events(const hw::PmcSource& src, const std::vector<std::string>& events) {
  std::string out;
  for (const auto& e : events)
    if (!src.provides(e)) out += (out.empty() ? "" : ", ") + e;
  return out;
}

}  // namespace

NrtGuard::NrtGuard(rclcpp::Node::SharedPtr node, NrtGuardOptions options,
                   const hw::WorkCounters* work)
    : node_(std::move(node)),
      opt_(std::move(options)),
      work_(work),
      driver_(opt_.sampling, opt_.watchdog_ms * rosguard::kNsPerMs) {
  if (opt_.name.empty()) opt_.name = node_->get_name();
  const auto cpus = hw::usable_cpus();
  if (std::find(cpus.begin(), cpus.end(), opt_.core) == cpus.end())
    throw std::invalid_argument("rosguard: nRT node '" + opt_.name + "': core " +
                                std::to_string(opt_.core) + " is not one this process may use (" +
                                hw::cpu_list_text(cpus) + ")");
  if (opt_.sampling != rosguard::Sampling::Self && opt_.sampling != rosguard::Sampling::External)
    throw std::invalid_argument("rosguard: nRT node '" + opt_.name +
                                "': sampling is self or external");

  // The PMC source, chosen as the hw backend chooses it (hw/metric_plan.cpp).
  auto perf = hw::make_perf_source();
  const auto perf_why = perf->unavailable_reason();
  const std::string perf_lacks = perf_why ? std::string() : missing_events(*perf, opt_.events);
  const std::string no_pmu = perf_why ? "no usable hardware PMU (" + *perf_why + ")"
                                      : "the PMU does not count " + perf_lacks;
  const auto use_software = [&] {
    source_ = hw::make_software_source();
    if (auto why = source_->unavailable_reason())
      throw std::runtime_error("rosguard: nRT node '" + opt_.name +
                               "': perf software events do not work here either: " + *why);
    source_name_ = "software";
    group_events_ = hw::software_group_events();
  };
  if (opt_.pmc_source == "perf" || (opt_.pmc_source == "auto" && !perf_why && perf_lacks.empty())) {
    if (perf_why || !perf_lacks.empty())
      throw std::runtime_error("rosguard: nRT node '" + opt_.name + "': pmc_source perf: " +
                               no_pmu + "; use auto, instrumented or software");
    source_ = std::move(perf);
    source_name_ = "perf";
    group_events_ = opt_.events;
  } else if (opt_.pmc_source == "instrumented" || (opt_.pmc_source == "auto" && work_)) {
    if (!work_)
      throw std::runtime_error("rosguard: nRT node '" + opt_.name +
                               "': pmc_source instrumented counts the lines of a "
                               "rosguard_rclcpp::Workload: give NrtGuard its counters()");
    source_ = hw::make_instrumented_source();
    if (auto lacks = missing_events(*source_, opt_.events); !lacks.empty())
      throw std::runtime_error("rosguard: nRT node '" + opt_.name +
                               "': the instrumented source does not count " + lacks);
    source_name_ = "instrumented";
    group_events_ = opt_.events;
    if (opt_.pmc_source == "auto")
      fallback("pmc_source auto: " + no_pmu +
               "; counting the lines the node's rosguard_rclcpp::Workload touches (instrumented)");
  } else {
    use_software();
    if (opt_.pmc_source == "auto")
      fallback("pmc_source auto: " + no_pmu +
               " and no rosguard_rclcpp::Workload counted: the software source (the controller "
               "budgets task_clock time, not bytes)");
  }

  // The throttle: the paper's SCHED_FIFO idle loop, or the idle throttle where SCHED_FIFO is
  // refused (hw/throttle/throttle.h).
  const auto refused = hw::fifo_refused();
  if (opt_.throttle == "fifo" && refused)
    throw std::runtime_error("rosguard: nRT node '" + opt_.name +
                             "': throttle fifo: SCHED_FIFO is refused here (" + *refused +
                             "); use throttle auto or idle");
  throttle_kind_ = (opt_.throttle == "idle" || (opt_.throttle == "auto" && refused))
                       ? hw::ThrottleKind::Idle
                       : hw::ThrottleKind::Fifo;
  if (opt_.throttle == "auto" && refused)
    fallback("SCHED_FIFO refused (" + *refused +
             "): throttle idle, the nominal work runs under SCHED_IDLE and the callbacks under "
             "SCHED_OTHER with nice values in the paper's order; THR leaves the work a sliver");
  sched_ = hw::throttle_sched(throttle_kind_, hw::SchedClass::Fifo);
  throttler_ = hw::make_throttler(throttle_kind_);

  // The three callback groups, kept off the node's own executor.
  const auto group = [&] {
    return node_->create_callback_group(rclcpp::CallbackGroupType::MutuallyExclusive, false);
  };
  cfb_group_ = group();
  thr_group_ = group();
  pmc_group_ = group();
  rclcpp::SubscriptionOptions sub_opt;
  sub_opt.callback_group = cfb_group_;
  command_sub_ = node_->create_subscription<Command>(
      rosguard_topic(opt_.ns, opt_.name, "command"), rclcpp::QoS(100).reliable(),
      [this](const Command& m) { on_command(m); }, sub_opt);
  sample_pub_ = node_->create_publisher<rosguard_msgs::msg::PmcSample>(
      rosguard_topic(opt_.ns, opt_.name, "pmc"), rclcpp::QoS(100).reliable());
  // Zero-time timers, started (reset) by CFB: THR's idle loop, and the self-sampling baseline.
  thr_timer_ = node_->create_wall_timer(
      std::chrono::nanoseconds(0), [this] { on_thr(); }, thr_group_);
  thr_timer_->cancel();
  baseline_timer_ = node_->create_wall_timer(
      std::chrono::nanoseconds(0), [this] { on_pmc(true); }, pmc_group_);
  baseline_timer_->cancel();
  if (opt_.sampling == rosguard::Sampling::Self)
    pmc_timer_ = node_->create_wall_timer(
        std::chrono::microseconds(opt_.sampling_period_us), [this] { on_pmc(false); }, pmc_group_);
  watchdog_timer_ = node_->create_wall_timer(
      std::chrono::milliseconds(std::max<std::int64_t>(1, opt_.watchdog_ms / 4)),
      [this] {
        const auto now = hw::now_ns();
        if (auto d = driver_.watchdog_deadline(); d && *d <= now) {
          RCLCPP_WARN(node_->get_logger(),
                      "rosguard: nRT node '%s': the controller was silent for %ld ms: back to "
                      "nominal",
                      opt_.name.c_str(), static_cast<long>(opt_.watchdog_ms));
          apply(driver_.watchdog(now), now, -1);
        }
      },
      cfb_group_);

  activation_us_.reserve(1 << 14);
  thr_us_.reserve(1 << 14);
  pmc_us_.reserve(1 << 16);
  read_us_.reserve(1 << 16);
  thr_entries_.reserve(1 << 14);
  start_thread("-cfb", hw::prio::kCfb, cfb_group_, cfb_exec_, cfb_thread_);
  start_thread("-thr", hw::prio::kThr, thr_group_, thr_exec_, thr_thread_);
  start_thread("-pmc", hw::prio::kPmc, pmc_group_, pmc_exec_, pmc_thread_);
  RCLCPP_INFO(node_->get_logger(),
              "rosguard: nRT node '%s' on core %d: CFB > THR > PMC > NCT (%s), %s sampling "
              "every %ld us, pmc source %s, throttle %s; commands on %s",
              opt_.name.c_str(), opt_.core,
              sched_.control == hw::SchedClass::Fifo ? "SCHED_FIFO 50/40/30/20"
                                                     : "SCHED_OTHER by nice, work SCHED_IDLE",
              std::string(rosguard::to_string(opt_.sampling)).c_str(),
              static_cast<long>(opt_.sampling_period_us), source_name_.c_str(),
              std::string(hw::to_string(throttle_kind_)).c_str(), command_sub_->get_topic_name());
}

NrtGuard::~NrtGuard() {
  stop();
}

void NrtGuard::fallback(const std::string& what) {
  RCLCPP_WARN(node_->get_logger(), "rosguard: nRT node '%s': fallback: %s", opt_.name.c_str(),
              what.c_str());
  std::lock_guard lock(fallbacks_mutex_);
  fallbacks_.push_back(what);
}

std::vector<std::string> NrtGuard::fallbacks() const {
  std::lock_guard lock(fallbacks_mutex_);
  return fallbacks_;
}

void NrtGuard::start_thread(const char* suffix, int priority,
                            rclcpp::CallbackGroup::SharedPtr group,
                            std::unique_ptr<rclcpp::executors::SingleThreadedExecutor>& exec,
                            std::unique_ptr<hw::RtThread>& thread) {
  exec = std::make_unique<rclcpp::executors::SingleThreadedExecutor>();
  exec->add_callback_group(group, node_->get_node_base_interface());
  auto* e = exec.get();
  auto context = node_->get_node_base_interface()->get_context();
  const std::string name = opt_.name.substr(0, 11) + suffix;  // 15 characters are kept
  thread = std::make_unique<hw::RtThread>(
      hw::ThreadSpec{name, opt_.core, sched_.control, priority},
      [this, e, context] {
        while (!stopping_.load(std::memory_order_acquire) && context->is_valid())
          e->spin_once(kSpinSlice);
      },
      [this](const std::string& t, std::exception_ptr err) {
        try {
          std::rethrow_exception(err);
        } catch (const std::exception& x) {
          RCLCPP_ERROR(node_->get_logger(), "rosguard: thread %s failed: %s", t.c_str(), x.what());
        }
      });
  const auto& o = thread->outcome();
  if (!o.pinned || (sched_.control == hw::SchedClass::Fifo && !o.fifo)) fallback(o.detail);
}

void NrtGuard::on_command(const Command& m) {
  const auto now = hw::now_ns();
  driver_.heard(now);
  if (m.command == Command::KEEPALIVE) return;
  const auto c = model_command(m.command);
  if (!c) {
    RCLCPP_WARN(node_->get_logger(), "rosguard: nRT node '%s': unknown command %u ignored",
                opt_.name.c_str(), static_cast<unsigned>(m.command));
    return;
  }
  const std::int64_t cause = m.cause_ns > 0 ? m.cause_ns : -1;
  ++stats_.commands;
  apply(driver_.command(now, *c, cause), now, cause);
}

void NrtGuard::apply(const rosguard::NrtEffects& fx, std::int64_t now, std::int64_t cause) {
  if (fx.throttle) {
    thr_cause_.store(cause, std::memory_order_release);
    thr_taken_.store(now, std::memory_order_release);
    state_.store(NodeState::Thr, std::memory_order_release);
    thr_timer_->reset();  // the zero-time timer: THR runs as soon as CFB returns
    thr_group_->trigger_notify_guard_condition();
  } else {
    state_.store(driver_.state(), std::memory_order_release);
  }
  if (fx.unthrottle) thr_waker_.notify();
  if (fx.baseline) {
    baseline_timer_->reset();
    pmc_group_->trigger_notify_guard_condition();
  }
}

void NrtGuard::on_thr() {
  thr_timer_->cancel();
  if (state_.load(std::memory_order_acquire) != NodeState::Thr) return;  // already left
  const auto t = hw::now_ns();
  thr_entries_.push_back(t);
  if (const auto cause = thr_cause_.load(std::memory_order_acquire); cause > 0)
    activation_us_.push_back(hw::ns_to_us(t - cause));
  if (const auto taken = thr_taken_.load(std::memory_order_acquire); taken > 0)
    thr_us_.push_back(hw::ns_to_us(t - taken));
  throttles_.fetch_add(1, std::memory_order_acq_rel);
  throttler_->hold(
      [this] {
        return state_.load(std::memory_order_acquire) == NodeState::Thr &&
               !stopping_.load(std::memory_order_acquire);
      },
      thr_waker_);
}

void NrtGuard::on_pmc(bool baseline) {
  if (baseline) baseline_timer_->cancel();
  if (!group_ready_.load(std::memory_order_acquire)) return;
  if (opt_.sampling != rosguard::Sampling::Self) return;
  if (!baseline && state_.load(std::memory_order_acquire) != NodeState::On) return;
  if (baseline && pmc_timer_) pmc_timer_->reset();  // the period restarts at the baseline
  const auto t0 = hw::now_ns();
  std::array<rosguard::CounterValue, hw::kMaxGroupEvents> v{};
  const std::size_t n = group_->size();
  group_->read(std::span(v.data(), n));
  const auto t1 = hw::now_ns();
  rosguard_msgs::msg::PmcSample m;
  m.entity = 0;
  m.stamp_ns = t1;
  m.count = static_cast<std::uint8_t>(n);
  for (std::size_t i = 0; i < n; ++i) {
    m.value[i] = v[i].value;
    m.time_enabled_ns[i] = v[i].time_enabled_ns;
    m.time_running_ns[i] = v[i].time_running_ns;
  }
  sample_pub_->publish(m);
  const auto t2 = hw::now_ns();
  pmc_us_.push_back(hw::ns_to_us(t2 - t0));
  read_us_.push_back(hw::ns_to_us(t1 - t0));
}

void NrtGuard::enter_nominal() {
  if (nct_sched_) throw std::logic_error("rosguard: enter_nominal() called twice");
  hw::ThreadSpec spec{opt_.name.substr(0, 11) + "-nct", opt_.core, sched_.work, hw::prio::kNct};
  nct_sched_.emplace(spec);
  const auto& o = nct_sched_->outcome();
  if (!o.pinned || (sched_.work == hw::SchedClass::Fifo && !o.fifo) ||
      (sched_.work == hw::SchedClass::Idle && !o.idle))
    fallback(o.detail);
  hw::PmcTarget target;
  target.kind = hw::PmcTarget::Kind::Thread;
  target.pid = hw::current_tid();
  target.work = work_;
  group_ = source_->open(group_events_, target);
  group_ready_.store(true, std::memory_order_release);
}

void NrtGuard::spin_nominal(rclcpp::Executor& executor) {
  enter_nominal();
  nominal_exec_ = &executor;
  auto context = node_->get_node_base_interface()->get_context();
  while (!stopping_.load(std::memory_order_acquire) && context->is_valid() && rclcpp::ok(context))
    executor.spin_once(kSpinSlice);
  nominal_exec_ = nullptr;
  nct_sched_.reset();
}

void NrtGuard::stop() {
  if (stopped_) return;
  stopped_ = true;
  stopping_.store(true, std::memory_order_release);
  state_.store(NodeState::Off, std::memory_order_release);
  thr_waker_.notify();
  for (auto* e : {cfb_exec_.get(), thr_exec_.get(), pmc_exec_.get()})
    if (e) e->cancel();
  for (auto* t : {cfb_thread_.get(), thr_thread_.get(), pmc_thread_.get()})
    if (t) t->join();
  driver_.finish(hw::now_ns());
  for (auto* t : {&thr_timer_, &baseline_timer_, &pmc_timer_, &watchdog_timer_})
    if (*t) (*t)->cancel();
}

NrtGuardStats NrtGuard::stats() const {
  NrtGuardStats s = stats_;
  s.activation_delays_us = activation_us_;
  s.thr_activations_us = thr_us_;
  s.pmc_callbacks_us = pmc_us_;
  s.pmc_reads_us = read_us_;
  s.thr_entries_ns = thr_entries_;
  s.throttles = throttles_.load();
  s.throttled_ns = driver_.throttled_ns();
  s.watchdog_fired = driver_.watchdog_fired();
  return s;
}

}  // namespace rosguard_rclcpp

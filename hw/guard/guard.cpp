#include "hw/guard/guard.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <ostream>

#include "core/error.h"
#include "hw/common/clock.h"
#include "hw/common/sys.h"
#include "regulator/regulator.h"

namespace rosguard::hw {
namespace {

std::string fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

const WorkloadInfo& no_workload() {
  static const WorkloadInfo w{};
  return w;
}

}  // namespace

// The node threads report failures here (any thread); the main thread looks at them.
struct Guard::ErrorSink {
  std::mutex mutex;
  std::vector<std::string> errors;
};

Guard::Guard(GuardSettings settings, ActivitySource& activity, GuardPublisher& publisher,
             std::ostream& log)
    : s_(std::move(settings)),
      activity_source_(activity),
      publisher_(publisher),
      log_(log),
      activity_(s_.rt.size(), s_.max_active_ns) {
  // What a killed guard of this name left behind is undone before anything else happens.
  const std::string record = repair_after_crash();
  check_cores();
  choose_source();
  ThrottleNeeds needs;
  needs.mode = s_.throttle;
  needs.scenario_sched = SchedClass::Fifo;
  needs.commands_only = true;  // processes: the freezer can hold them
  needs.core = s_.nrt.front().core;
  throttle_ = choose_throttle(needs);

  auto errors = std::make_shared<ErrorSink>();
  const RtThread::ErrorHandler on_error = [errors, this](const std::string& thread,
                                                         std::exception_ptr e) {
    const std::string what = exception_text(e);
    std::lock_guard lock(errors->mutex);
    errors->errors.push_back(thread + ": " + what);
    notes_waker_.notify();
  };

  wire(on_error, record);
  last_sample_t_.assign(s_.nrt.size(), 0);
  sample_count_.assign(s_.nrt.size(), 0);
  shown_state_.assign(s_.nrt.size(), NodeState::Off);
  stats_.last_budget_bytes.assign(s_.nrt.size(), 0.0);
  error_sink_ = errors;
}

// The crash record of this guard's name (empty without a state_dir): what a guard of that name
// left changed when it was killed is repaired first.
std::string Guard::repair_after_crash() {
  std::string record;
  if (!s_.state_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(s_.state_dir, ec);
    if (ec) {
      start_log_.push_back("warning: fallback (state_dir): cannot create " + s_.state_dir + " (" +
                           ec.message() +
                           "): no crash record, so processes this guard changes stay changed if "
                           "it is killed");
    } else {
      record = s_.state_dir + "/" + s_.name + ".record";
      for (const auto& line : CoreTasks::repair(record))
        start_log_.push_back("repaired after a guard that did not stop cleanly: " + line);
    }
  }
  return record;
}

std::vector<std::pair<std::string, std::string>> core_problems(const GuardSettings& s) {
  const auto cpus = usable_cpus();
  std::vector<std::pair<std::string, std::string>> problems;
  const auto check = [&](const std::string& at, int core) {
    if (std::find(cpus.begin(), cpus.end(), core) == cpus.end())
      problems.emplace_back(
          at, "core " + std::to_string(core) +
                  " is not usable on this host (usable CPUs: " + cpu_list_text(cpus) + ")");
  };
  for (std::size_t i = 0; i < s.nrt.size(); ++i)
    check("/nrt/" + std::to_string(i) + "/core", s.nrt[i].core);
  if (s.controller_core >= 0) check("/controller/core", s.controller_core);
  return problems;
}

// Every nRT core, and the controller's, must be usable here.
void Guard::check_cores() const {
  if (const auto problems = core_problems(s_); !problems.empty())
    throw InputError(s_.file, problems);
}

// How the cores are measured: the hardware PMU's L2 refills and write-backs where perf provides
// them (pmc_source perf, or auto), else the CPU time of the processes on each core (cputime).
void Guard::choose_source() {
  perf_ = make_perf_source();
  std::string lacks;  // the events of the metric the PMU does not count, named
  for (const char* e : {"l2d_cache_refill", "l2d_cache_wb"})
    if (!perf_->provides(e)) lacks += (lacks.empty() ? "" : ", ") + std::string(e);
  const auto perf_why = perf_->unavailable_reason();
  const std::string no_pmu = "no usable hardware PMU (" +
                             perf_why.value_or("it does not count the metric's " + lacks) + ")";
  const bool perf_ok = !perf_why && lacks.empty();
  if (s_.source == GuardSource::Perf && !perf_ok)
    throw InputError(s_.file, "/hw/pmc_source",
                     "pmc_source \"perf\": " + no_pmu + " here; use \"auto\" or \"cputime\"");
  if (s_.source == GuardSource::Perf || (s_.source == GuardSource::Auto && perf_ok)) {
    source_name_ = "perf";
    source_why_ = "perf: the core's hardware PMU per CPU (L2 refills + write-backs x 64 B, Eq. 1)";
    s_.regulation.metric = MetricSpec{};
    group_events_ = {"l2d_cache_refill", "l2d_cache_wb"};
  } else {
    source_name_ = "cputime";
    const auto no_clock = task_clock_unavailable();
    task_clock_ = !no_clock;
    source_why_ =
        "cputime: " + (s_.source == GuardSource::Auto ? no_pmu + ", so " : std::string()) +
        "the budget is CPU time, not bandwidth: the CPU time of the processes pinned to each "
        "core " +
        (task_clock_ ? "(each thread's perf task clock)" : "(/proc/<tid>/schedstat)") +
        " x reference_mbps; a core may run its processes threshold_pct % of each window";
    if (no_clock)
      start_log_.push_back("warning: fallback (cputime): no perf task clock opens here (" +
                           *no_clock +
                           "), so CPU time is read from /proc/<tid>/schedstat, which moves only at "
                           "the scheduler's ticks: a core may overrun its budget by up to a tick "
                           "per window");
    MetricSpec& m = s_.regulation.metric;
    m.line_bytes = 64;
    m.events = {{"task_clock", s_.regulation.params.reference_mbps * kBytesPerMb / 1e9 / 64.0}};
    m.counter_bits = 64;
    group_events_ = {"cpu_time"};
  }
}

// One nRT runner per core, measured by its own counter group, and the controller over them
// (external sampling); the core tasks that the throttle holds, recorded in `record`.
void Guard::wire(const RtThread::ErrorHandler& on_error, const std::string& record) {
  rt_pub_ = rt_topic_.add_publisher();
  std::vector<Topic<ControlMsg>*> control_ptrs;
  std::vector<CounterGroup*> groups;
  std::vector<CoreTasks::Core> task_cores;
  ControllerConfig cc;
  cc.core = s_.controller_core;
  cc.sched = SchedClass::Fifo;
  cc.sampling = Sampling::External;
  cc.sampling_period_ns = s_.regulation.sampling_period_ns;
  cc.keepalive_ns = std::max<TimeNs>(kNsPerMs, s_.watchdog_ns / 4);
  // CPU time is spent at one ns per ns at most: a read is due when a core could have spent its
  // budget's remainder, not only every sampling period (ControllerDriverConfig).
  if (source_name_ == "cputime")
    cc.max_bytes_per_ns = s_.regulation.params.reference_mbps * kBytesPerMb / 1e9;
  cc.metric_events = group_events_.size();
  cc.keep_measurements = false;
  cc.notes = &notes_;
  cc.notes_waker = &notes_waker_;
  for (std::size_t i = 0; i < s_.nrt.size(); ++i) {
    controls_.push_back(std::make_unique<InprocTopic<ControlMsg>>());
    control_ptrs.push_back(controls_.back().get());
    NrtConfig c;
    c.name = s_.nrt[i].name;
    c.entity = i;
    c.core = s_.nrt[i].core;
    c.sampling = Sampling::External;
    c.sampling_period_ns = s_.regulation.sampling_period_ns;
    c.watchdog_ns = s_.watchdog_ns;
    c.sched = SchedClass::Fifo;
    c.throttle = throttle_.kind;
    c.freezer_root = throttle_.freezer_root.value_or("");
    c.foreign = true;
    c.keep_measurements = false;
    c.group_events = group_events_;
    c.metric_events = group_events_.size();
    nodes_.push_back(std::make_unique<NrtRunner>(c, no_workload(), *perf_, *controls_.back(),
                                                 samples_, engine_waker_, on_error, now_ns()));
    std::unique_ptr<CounterGroup> group;
    CpuTimeGroup* cpu = nullptr;
    if (source_name_ == "perf") {
      PmcTarget t;
      t.kind = PmcTarget::Kind::Cpu;
      t.pid = -1;
      t.cpu = c.core;
      group = perf_->open(group_events_, t);
    } else {
      auto g = std::make_unique<CpuTimeGroup>(task_clock_);
      cpu = g.get();
      group = std::move(g);
    }
    groups.push_back(group.get());
    nodes_.back()->set_group(std::move(group));
    cputime_.push_back(cpu);
    task_cores.push_back({c.core, nodes_.back()->cgroup(), cpu});
    cc.entity_cores.push_back(c.core);
    cc.group_sizes.push_back(group_events_.size());
  }
  if (s_.regulation.nodes.nrt != s_.nrt.size())
    throw ContractError("the guard's regulation setup is for " +
                        std::to_string(s_.regulation.nodes.nrt) + " core(s), it regulates " +
                        std::to_string(s_.nrt.size()));
  controller_ =
      std::make_unique<Controller>(cc, s_.regulation.make_regulator(), rt_topic_, samples_,
                                   control_ptrs, nullptr, engine_waker_, on_error, now_ns());
  controller_->set_groups(groups);
  tasks_ = std::make_unique<CoreTasks>(throttle_.kind, task_cores, record, s_.pin_processes);
}

Guard::~Guard() {
  shutdown();
}

void Guard::logln(const std::string& line) {
  log_ << wall_clock_iso() << " guard " << s_.name << ": " << line << '\n' << std::flush;
  ++stats_.log_lines;
}

void Guard::log_limited(const std::string& key, const std::string& line) {
  const TimeNs now = now_ns();
  // Keys come and go with publishers (a GUID per RT program run): quiet ones are forgotten.
  if (repeats_.size() > kMaxLogKeys) {
    flush_suppressed();
    std::erase_if(repeats_, [&](const auto& r) { return now - r.second.last >= kLogRepeatNs; });
  }
  auto [it, fresh] = repeats_.try_emplace(key);
  Repeat& r = it->second;
  if (!fresh && now - r.last < kLogRepeatNs) {
    ++r.suppressed;
    ++stats_.log_suppressed;
    return;
  }
  std::string more;
  if (r.suppressed)
    more = " (and " + std::to_string(r.suppressed) + " more like it in the last " +
           fmt(static_cast<double>(now - r.last) / 1e9) + " s, not logged)";
  r = {now, 0};
  logln(line + more);
}

void Guard::flush_suppressed() {
  for (auto& [key, r] : repeats_)
    if (r.suppressed) {
      logln(std::to_string(r.suppressed) + " more of '" + key + "' not logged");
      r.suppressed = 0;
    }
}

// The activity source's thread. Only the node's own transitions reach the controller.
void Guard::on_activity(const ActivitySignal& a) {
  std::lock_guard lock(activity_mutex_);
  const TimeNs now = now_ns();
  if (a.gone) {
    for (const auto& r : activity_.gone(a.publisher)) {
      ++stats_.activity_gone;
      release(r, now, "its publisher is gone (writer deleted or lost): counted as its 'false'");
    }
    notes_waker_.notify();
    return;
  }
  if (a.rt >= s_.rt.size()) return;
  const std::string& node = s_.rt[a.rt];
  const auto v = activity_.set(a.rt, a.publisher, a.active, now);
  const std::string from = " (publisher " + a.publisher + ")";
  std::string line;
  switch (v) {
    case ActivityStates::Verdict::Started:
    case ActivityStates::Verdict::Ended:
      rt_topic_.publish(rt_pub_, RtEventMsg{a.rt, a.active, now});
      line = node + (a.active ? ": active" : ": inactive") + from;
      break;
    case ActivityStates::Verdict::Joined:
      line = node + ": active from a further publisher" + from +
             "; it stays active until every "
             "publisher that said 'true' says 'false' or is gone";
      break;
    case ActivityStates::Verdict::Left:
      line = node + ": 'false'" + from + "; still active for " +
             std::to_string(activity_.holders(a.rt)) + " other publisher(s)";
      break;
    case ActivityStates::Verdict::Duplicate:
      ++stats_.activity_ignored;
      line = "ignored a repeated 'true' for " + node + from + ": it holds the node active already";
      break;
    case ActivityStates::Verdict::Unmatched:
      ++stats_.activity_ignored;
      line = "ignored 'false' for " + node + from +
             ": that publisher had not said 'true' (the node "
             "stays " +
             (activity_.active(a.rt) ? "active" : "inactive") + ")";
      break;
  }
  activity_log_.emplace_back(node + " " + to_string(v) + " " + a.publisher, std::move(line));
  notes_waker_.notify();
}

// Under activity_mutex_.
void Guard::release(const ActivityStates::Release& r, TimeNs now, const std::string& why) {
  const std::string& node = s_.rt[r.rt];
  if (r.node_ended) rt_topic_.publish(rt_pub_, RtEventMsg{r.rt, false, now});
  activity_log_.emplace_back(
      node + " released " + r.publisher,
      "warning: " + node + ": active for " + fmt(static_cast<double>(now - r.since) / 1e9) +
          " s from publisher " + r.publisher + ", " + why +
          (r.node_ended ? "; the node is inactive" : "; other publishers still hold it"));
}

void Guard::expire_activity() {
  std::lock_guard lock(activity_mutex_);
  const TimeNs now = now_ns();
  for (const auto& r : activity_.expire(now)) {
    ++stats_.activity_expired;
    release(r, now,
            "longer than activity.max_active_ms (" +
                fmt(static_cast<double>(s_.max_active_ns) / 1e6) + " ms): counted as its 'false'");
  }
}

void Guard::start() {
  for (const auto& line : start_log_)
    logln(line);
  logln("measuring with " + source_why_);
  std::string holds;
  for (const auto& m : throttle_.measured)
    holds += (holds.empty() ? "" : ", ") + describe_hold(m);
  logln("throttle '" + std::string(to_string(throttle_.kind)) + "' (" + throttle_.why +
        "; measured hold, nRT progress while throttled / nominal: " + holds + ")");
  if (!throttle_.fallback.empty()) logln("warning: fallback (throttle): " + throttle_.fallback);
  for (const auto& who : activity_source_.exposure())
    logln("warning: " + who);
  for (auto& n : nodes_)
    n->start();
  controller_->start();
  for (const auto& o : outcomes())
    if (!o.detail.empty()) logln("warning: " + o.detail);
  rescan();
  activity_source_.start(s_.rt, [this](const ActivitySignal& a) { on_activity(a); });
  std::string cores;
  for (const auto& n : s_.nrt)
    cores += (cores.empty() ? "" : ", ") + n.name + " (CPU " + std::to_string(n.core) + ")";
  std::string rts;
  for (const auto& r : s_.rt)
    rts += (rts.empty() ? "" : ", ") + r;
  logln("regulating " + cores + " with " + s_.regulation.describe() + ", while any of [" + rts +
        "] is active (" + activity_source_.describe() + "); publishing to " +
        publisher_.describe());
  started_ = true;
}

std::vector<SchedOutcome> Guard::outcomes() const {
  std::vector<SchedOutcome> out;
  for (const auto& n : nodes_)
    for (const auto& o : n->outcomes())
      out.push_back(o);
  out.push_back(controller_->outcome());
  return out;
}

void Guard::rescan() {
  for (const auto& c : tasks_->rescan()) {
    if (c.core < 0) {  // a process of pin_processes the guard could not pin
      logln("left alone: pid " + std::to_string(c.pid) + " tid " + std::to_string(c.tid) + " (" +
            c.comm + "): " + c.note);
      continue;
    }
    const std::string& core =
        s_.nrt[static_cast<std::size_t>(std::distance(
                   s_.nrt.begin(), std::find_if(s_.nrt.begin(), s_.nrt.end(),
                                                [&](const auto& n) { return n.core == c.core; })))]
            .name;
    logln(core + ": " + (c.added ? "regulating" : "released") + " pid " + std::to_string(c.pid) +
          " tid " + std::to_string(c.tid) + (c.comm.empty() ? "" : " (" + c.comm + ")") +
          (c.note.empty() ? "" : ": " + c.note));
  }
  if (const auto left = tasks_->take_unregulated(); !left.empty()) {
    std::string names;
    for (std::size_t i = 0; i < left.size() && i < 10; ++i)
      names += (i ? ", " : "") + left[i];
    log_limited(
        "not regulated",
        "not regulated: " + std::to_string(left.size()) +
            " process(es) whose threads may run on an nRT core but are not pinned to one (" +
            names + (left.size() > 10 ? ", ..." : "") +
            "): pin them to one nRT core (taskset -c) or name them in pin_processes");
  }
  next_rescan_ = now_ns() + s_.rescan_ns;
}

void Guard::drain() {
  std::vector<std::pair<std::string, std::string>> heard;
  {
    std::lock_guard lock(activity_mutex_);
    heard.swap(activity_log_);
  }
  for (const auto& [key, line] : heard)
    log_limited(key, line);
  ControllerNote n;
  while (notes_.pop(n)) {
    const std::size_t e = n.entity < s_.nrt.size() ? n.entity : 0;
    switch (n.kind) {
      case ControllerNote::Kind::Sample: {
        ++stats_.samples;
        GuardSample g{s_.nrt[e].name, s_.nrt[e].core, n.t,     n.value, 0.0,
                      n.used,         n.budget,       n.value2};
        if (last_sample_t_[e] > 0 && n.t > last_sample_t_[e])
          g.mbps = n.value / kBytesPerMb / (static_cast<double>(n.t - last_sample_t_[e]) / 1e9);
        last_sample_t_[e] = n.t;
        stats_.last_budget_bytes[e] = n.budget;
        if (sample_count_[e]++ % s_.publish_every == 0) publisher_.sample(g);
        break;
      }
      case ControllerNote::Kind::Command: {
        const NodeState next = n.command == Command::Thr   ? NodeState::Thr
                               : n.command == Command::Off ? NodeState::Off
                                                           : NodeState::On;
        if (n.command == Command::Thr) {
          ++stats_.throttles;
          if (stats_.core_throttles.size() < s_.nrt.size())
            stats_.core_throttles.resize(s_.nrt.size());
          ++stats_.core_throttles[e];
        }
        if (next != shown_state_[e]) {
          const std::string change = s_.nrt[e].name + ": " +
                                     std::string(to_string(shown_state_[e])) + " -> " +
                                     std::string(to_string(next));
          log_limited(change, change + " (" + std::string(to_string(n.command)) + ")");
        }
        shown_state_[e] = next;
        publisher_.command({s_.nrt[e].name, s_.nrt[e].core, n.t, n.command, n.cause});
        break;
      }
      case ControllerNote::Kind::Activation:
        stats_.core_throttles.resize(s_.nrt.size());
        if (n.active) {
          ++stats_.activations;
          activation_since_ = n.t;
          activation_throttles_ = stats_.core_throttles;
          log_limited("regulation active", "regulation active (an RT node started)");
        } else {
          // Every activation's end, never folded: what each job's regulation did can be read
          // back (one line per RT job at most).
          std::uint64_t total = 0;
          std::string cores;
          for (std::size_t i = 0; i < s_.nrt.size(); ++i) {
            const std::uint64_t k =
                stats_.core_throttles[i] -
                (i < activation_throttles_.size() ? activation_throttles_[i] : 0);
            total += k;
            cores += (i ? ", " : "") + s_.nrt[i].name + " " + std::to_string(k);
          }
          logln("regulation inactive (every RT node finished): activation " +
                std::to_string(stats_.activations) + " lasted " +
                fmt(static_cast<double>(n.t - activation_since_) / 1e6) + " ms, " +
                std::to_string(total) + " THR (" + cores + ")");
        }
        publisher_.active(n.t, n.active);
        break;
      case ControllerNote::Kind::Policy:
        ++stats_.policy_swaps;
        logln("new policy parameters in force from the next window");
        break;
      case ControllerNote::Kind::Budget:
      case ControllerNote::Kind::WindowClosed:
        break;
    }
  }
  stats_.notes_dropped = controller_->notes_dropped();
  std::lock_guard lock(error_sink_->mutex);
  if (!error_sink_->errors.empty())
    throw RunError("guard " + s_.name + ": a node thread failed: " + error_sink_->errors.front());
}

void Guard::serve(TimeNs max_wait_ns) {
  const auto epoch = notes_waker_.epoch();
  expire_activity();
  drain();
  const TimeNs now = now_ns();
  if (now >= next_rescan_) {
    rescan();
    return;
  }
  notes_waker_.wait(epoch, std::min(now + max_wait_ns, next_rescan_));
}

void Guard::run(const std::function<bool()>& stop, const std::function<bool()>& reload_due,
                const std::function<std::optional<GuardSettings>()>& reload_settings) {
  while (!stop()) {
    if (reload_due && reload_due()) {
      if (auto next = reload_settings ? reload_settings() : std::nullopt) reload(*next);
    }
    serve(50 * kNsPerMs);
  }
}

bool Guard::reload(const GuardSettings& next) {
  std::string refused;
  const auto differs = [&](bool d, const char* key) {
    if (d) refused += (refused.empty() ? "" : ", ") + std::string(key);
  };
  differs(next.name != s_.name, "name");
  differs(next.controller_core != s_.controller_core, "controller.core");
  differs(next.rt != s_.rt, "rt");
  differs(next.nrt.size() != s_.nrt.size() ||
              !std::equal(next.nrt.begin(), next.nrt.end(), s_.nrt.begin(),
                          [](const auto& a, const auto& b) {
                            return a.name == b.name && a.core == b.core;
                          }),
          "nrt");
  const RegulationSetup& now = s_.regulation;
  const RegulationSetup& then = next.regulation;
  differs(then.policy.name != now.policy.name, "regulation.policy");
  differs(then.sampling_period_ns != now.sampling_period_ns, "regulation.sampling_period_us");
  differs(then.params.reference_mbps != now.params.reference_mbps, "regulation.reference_mbps");
  differs(then.scope != now.scope, "regulation.scope");
  differs(next.source != s_.source, "hw.pmc_source");
  differs(next.throttle != s_.throttle, "hw.throttle");
  differs(next.watchdog_ns != s_.watchdog_ns, "hw.watchdog_ms");
  differs(next.max_active_ns != s_.max_active_ns, "activity.max_active_ms");
  if (!refused.empty()) {
    logln("reload refused: " + refused +
          " changed (only regulation.threshold_pct and regulation.regulation_period_us can change "
          "while running; restart the guard for the rest); the running configuration stays");
    return false;
  }
  std::string what;
  if (then.params.threshold_pct != now.params.threshold_pct)
    what +=
        "threshold_pct " + fmt(now.params.threshold_pct) + " -> " + fmt(then.params.threshold_pct);
  if (then.params.regulation_period_ns != now.params.regulation_period_ns)
    what += std::string(what.empty() ? "" : ", ") + "regulation_period_us " +
            fmt(ns_to_us(now.params.regulation_period_ns)) + " -> " +
            fmt(ns_to_us(then.params.regulation_period_ns));
  const TimeNs rescan = next.rescan_ns;
  const std::size_t every = next.publish_every;
  if (what.empty()) {
    logln("reload: regulation unchanged");
  } else {
    // The running setup with the new parameters (the metric stays the chosen source's).
    RegulationSetup swapped = now;
    swapped.params = then.params;
    controller_->post_policy(swapped.make_policy());
    logln("reload: " + what + " (from the next window; regulation continues meanwhile)");
  }
  s_.regulation.params = then.params;
  s_.rescan_ns = rescan;
  s_.publish_every = every;
  return true;
}

void Guard::shutdown() {
  if (shut_) return;
  shut_ = true;
  activity_source_.stop();
  // Every core back to nominal first (its throttle released, its threads joined), then the
  // controller, then the processes get their scheduling and cgroups back.
  for (auto& n : nodes_)
    n->shutdown();
  controller_->shutdown();
  tasks_->restore();
  try {
    drain();
  } catch (const RunError&) {
  }
  nodes_.clear();
  flush_suppressed();
  if (started_)
    logln("stopped: " + std::to_string(s_.nrt.size()) +
          " core(s) back to nominal, every guard thread joined, " +
          std::to_string(realtime_threads().size()) + " thread(s) left under SCHED_FIFO");
  if (started_) {
    const GuardStats t = stats();
    std::string per_core;
    for (std::size_t i = 0; i < s_.nrt.size(); ++i)
      per_core += (i ? ", " : "") + s_.nrt[i].name + " (CPU " + std::to_string(s_.nrt[i].core) +
                  ") " + std::to_string(i < t.core_throttles.size() ? t.core_throttles[i] : 0);
    logln("totals: " + std::to_string(t.activations) + " activation(s), " +
          std::to_string(t.throttles) + " THR command(s) (" + per_core + "), " +
          std::to_string(t.samples) +
          " sample(s); activity: " + std::to_string(t.activity_ignored) + " message(s) ignored, " +
          std::to_string(t.activity_expired) + " activation(s) ended by activity.max_active_ms, " +
          std::to_string(t.activity_gone) +
          " by their publisher leaving; log: " + std::to_string(t.log_lines + 1) + " line(s), " +
          std::to_string(t.log_suppressed) + " repeat(s) not logged");
  }
}

GuardStats Guard::stats() const {
  std::lock_guard lock(activity_mutex_);  // the activity thread counts what it ignored
  return stats_;
}

std::vector<NodeState> Guard::states() const {
  std::vector<NodeState> out;
  for (const auto& n : nodes_)
    out.push_back(n->state());
  return out;
}

}  // namespace rosguard::hw

#include "system.h"

#include <cstdlib>
#include <map>
#include <memory>
#include <optional>
#include <systemc>

#include "core/error.h"
#include "engine/outcome.h"
#include "kernel/runtime.h"
#include "metric/metric.h"
#include "nodes/controller.h"
#include "nodes/nrt_node.h"
#include "nodes/rt_node.h"
#include "platform/contention.h"
#include "platform/core.h"
#include "platform/memory_system.h"

namespace rosguard::sim {
namespace {

bool g_elaborated = false;

constexpr TimeNs kStopPollNs = 5 * kNsPerMs;

std::vector<PmuEvent> metric_events(const MetricSpec& m) {
  std::vector<PmuEvent> out;
  for (const auto& e : m.events) {
    const auto ev = pmu_event(e.name);
    if (!ev) throw RunError("the sim PMU does not count event '" + e.name + "'");
    out.push_back(*ev);
  }
  return out;
}

// How one run of `profile` progresses in isolation on `cluster`: per segment (a phase of one
// repetition), its instructions and the time it takes alone, from the memory model's rates.
IsolationProgress isolation_progress(const WorkloadProfile& profile, const SimPlatform& platform,
                                     int cluster) {
  const ContentionModel model(platform);
  std::vector<double> phase_ns_per_inst;
  for (const Phase& ph : profile.phases)
    phase_ns_per_inst.push_back(1.0 / model.alone_inst_per_ns(ph, cluster));
  IsolationProgress p;
  double work = 0.0, time = 0.0;
  for (std::size_t s = 0; s < profile.segments(); ++s) {
    const double n = profile.segment_instructions(s);
    if (n <= 0.0) continue;
    work += n;
    time += n * phase_ns_per_inst[profile.phase_index(s)];
    p.work.push_back(work);
    p.time.push_back(time);
  }
  return p;
}

// The top of the model: every module of one run, and the end-of-run logic.
class Top : public sc_core::sc_module {
 public:
  SC_HAS_PROCESS(Top);
  Top(const sc_core::sc_module_name& name, const RunConfig& cfg)
      : sc_core::sc_module(name),
        cfg_(cfg),
        memory_("memory", cfg.platform, cfg.quantum_ns, rt_),
        bus_("bus", rt_),
        watchdog_("watchdog", rt_, [this](TimeNs t) { poll_stop(t); }) {
    rec_.trace = cfg.trace;
    const RegulationSetup& reg = cfg.regulation;
    const std::vector<PmuEvent> events = metric_events(reg.metric);

    if (!cfg.isolation) {
      if (reg.nodes.nrt != cfg.nrt.size())
        throw ContractError("the regulation setup is for " + std::to_string(reg.nodes.nrt) +
                            " nRT node(s), the run has " + std::to_string(cfg.nrt.size()));
      auto regulator = reg.make_regulator();
      ControllerConfig cc;
      cc.core = cfg.controller_core;
      cc.sampling = reg.sampling;
      cc.sampling_period_ns = reg.sampling_period_ns;
      cc.line_bytes = cfg.platform.line_bytes;
      cc.metric_events = events;
      controller_ = std::make_unique<Controller>("controller", std::move(cc), std::move(regulator),
                                                 cfg.platform.costs, cfg.seed, bus_, rt_, rec_);
      controller_->on_inactive([this](TimeNs t) { maybe_finish(t); });
    }

    for (std::size_t i = 0; i < cfg.nrt.size(); ++i) {
      const NrtSpec& n = cfg.nrt[i];
      NrtNodeConfig nc;
      nc.entity = i;
      nc.name = n.name;
      nc.loop = n.loop;
      nc.sampling = reg.sampling;
      nc.sampling_period_ns = reg.sampling_period_ns;
      nc.metric_events = events;
      nc.line_bytes = reg.metric.line_bytes;
      nc.freq_hz = cfg.platform.freq_mhz * 1e6;
      nrt_.push_back(std::make_unique<NrtNodeModel>(n.name.c_str(), std::move(nc), n.profile,
                                                    cfg.platform.costs, cfg.seed, core(n.core),
                                                    bus_, *controller_, rt_, rec_));
      NrtNodeModel* node = nrt_.back().get();
      controller_->add_entity(
          {n.name, n.core, [node](Command c, TimeNs cause) { node->on_command(c, cause); },
           [node]() -> const Pmu& { return node->core().pmu(); }, &node->core()});
      nrt_.back()->on_done([this](TimeNs t) { nrt_done(t); });
    }
    for (std::size_t i = 0; i < cfg.rt.size(); ++i) {
      const RtSpec& r = cfg.rt[i];
      RtNodeConfig rc{i, r.name, r.iterations, r.period_ns};
      rt_nodes_.push_back(std::make_unique<RtNodeModel>(r.name.c_str(), std::move(rc), r.profile,
                                                        cfg.platform.costs, cfg.seed, core(r.core),
                                                        bus_, controller_.get(), rt_, rec_));
      rt_nodes_.back()->on_job_start([this](TimeNs t) { rt_job_started(t); });
      rt_nodes_.back()->on_done([this](TimeNs t) { rt_done(t); });
      if (cfg.isolation) break;
    }
    if (controller_ && cores_.count(cfg.controller_core))
      controller_->run_on(&core(cfg.controller_core));  // shared with a node, as on a 2-core host
    SC_METHOD(begin);
  }

  SimReport run() {
    const bool finished = rt_.run(cfg_.limit_ns);
    if (interrupted_) throw Interrupted();
    if (!finished || !ended_)
      throw RunError("the simulation did not finish within " +
                     std::to_string(cfg_.limit_ns / kNsPerS) +
                     " s of simulated time: the RT jobs under contention (iterations x their "
                     "time) or an nRT run take longer than that, or a node never progresses");
    return report();
  }

 private:
  Core& core(int id) {
    auto it = cores_.find(id);
    if (it != cores_.end()) return *it->second;
    auto c = std::make_unique<Core>(("core" + std::to_string(id)).c_str(), id, cfg_.platform,
                                    memory_, rt_, cfg_.trace, cfg_.seed);
    return *cores_.emplace(id, std::move(c)).first->second;
  }

  void begin() {
    rt_.guarded([&] {
      const TimeNs now = now_ns();
      for (auto& n : nrt_)
        n->start(now);
      if (rt_nodes_.empty() && controller_) {
        // No RT node: regulation is active for the whole run (a virtual RT node 0).
        rt_window_start_ = now;
        controller_->enable(0, now, controller_->core());
      }
      for (auto& r : rt_nodes_)
        r->start(now);
      if (cfg_.stop_requested) watchdog_.set(now + kStopPollNs);
    });
  }

  void poll_stop(TimeNs now) {
    if (cfg_.stop_requested && cfg_.stop_requested()) {
      interrupted_ = true;
      rt_.stop();
      return;
    }
    watchdog_.set(now + kStopPollNs);
  }

  void rt_job_started(TimeNs now) {
    if (rt_window_start_ < 0) {
      rt_window_start_ = now;
      for (auto& n : nrt_)
        retired_start_.push_back(n->retired());
    }
  }

  void rt_done(TimeNs now) {
    for (auto& r : rt_nodes_)
      if (!r->done()) return;
    rt_window_end_ = now;
    for (auto& n : nrt_)
      retired_end_.push_back(n->retired());
    maybe_finish(now);
  }

  // A `once` nRT node finished. (`loop` nodes never finish: the RT nodes end the run.)
  void nrt_done(TimeNs now) {
    for (auto& n : nrt_)
      if (!n->config().loop && !n->done()) return;
    if (rt_nodes_.empty() && controller_) {
      rt_window_end_ = now;
      controller_->disable(0, now, controller_->core());
      return;  // finishes when the controller has deactivated
    }
    maybe_finish(now);
  }

  void maybe_finish(TimeNs now) {
    if (ended_) return;
    for (auto& r : rt_nodes_)
      if (!r->done()) return;
    for (auto& n : nrt_)
      if (!n->config().loop && !n->done()) return;
    if (controller_ && controller_->active()) return;
    if (rt_nodes_.empty() && controller_ && controller_->driver().totals().activations == 0) return;
    ended_ = true;
    end_ns_ = now;
    for (auto& n : nrt_)
      n->finish(now);
    if (controller_) controller_->finish(now);
    rt_.stop();
  }

  // What the sim measured of nRT node i: the instructions it retired over the RT window (first
  // RT job start -> last RT job end), weighed by their isolation time (isolation_progress), and
  // traffic over the regulation-active time (the whole run when never active).
  NrtMeasure measure(std::size_t i) {
    NrtNodeModel& n = *nrt_[i];
    NrtMeasure m;
    m.name = n.config().name;
    m.once = !n.config().loop;
    m.freq_hz = cfg_.platform.freq_mhz * 1e6;
    if (m.once) {
      m.runs = 1.0;
      if (n.done()) m.once_ns = static_cast<double>(n.finished_at());
    } else {
      m.window_ns = rt_window_end_ - rt_window_start_;
      m.work_from = retired_start_.at(i);
      m.work_to = retired_end_.at(i);
      m.progress = isolation_progress(n.profile(), cfg_.platform, n.core().cluster());
    }
    if (controller_ && controller_->driver().totals().activations > 0) {
      m.traffic = controller_->driver().totals().active[i];
      m.traffic_ns = controller_->driver().totals().active_ns;
    } else {
      const Pmu& p = n.core().pmu();
      m.traffic = {p.l3_accesses() * cfg_.platform.line_bytes, p[PmuEvent::CpuCycles], 0.0};
      m.traffic_ns = end_ns_;
    }
    return m;
  }

  SimReport report() {
    SimReport rep;
    rep.end_ns = end_ns_;
    for (auto& r : rt_nodes_) {
      std::vector<double> job_ns, response_ns;
      for (const auto& j : r->jobs()) {
        job_ns.push_back(static_cast<double>(j.end - j.start));
        response_ns.push_back(static_cast<double>(j.end - j.release));
      }
      std::optional<double> period_ns;
      if (r->config().period_ns) period_ns = static_cast<double>(*r->config().period_ns);
      rep.outcome.rt.push_back(rt_outcome(r->config().name, job_ns, response_ns, period_ns));
      rep.rt_jobs.push_back(r->jobs());
    }
    for (std::size_t i = 0; i < nrt_.size(); ++i)
      rep.outcome.nrt.push_back(nrt_outcome(measure(i), nrt_[i]->driver()));
    rep.outcome.samples = std::move(rec_.samples);
    if (controller_) rep.windows = controller_->driver().windows();
    rep.activations = rt_.activations();
    rep.memory_solves = memory_.solves();
    return rep;
  }

  const RunConfig& cfg_;
  Runtime rt_;
  Recorder rec_;
  MemorySystem memory_;
  MessageBus bus_;
  Timer watchdog_;
  std::map<int, std::unique_ptr<Core>> cores_;
  std::unique_ptr<Controller> controller_;
  std::vector<std::unique_ptr<NrtNodeModel>> nrt_;
  std::vector<std::unique_ptr<RtNodeModel>> rt_nodes_;
  TimeNs rt_window_start_ = -1, rt_window_end_ = -1;
  std::vector<double> retired_start_, retired_end_;
  bool ended_ = false;
  bool interrupted_ = false;
  TimeNs end_ns_ = 0;
};

}  // namespace

SimReport simulate(const RunConfig& config) {
  if (g_elaborated)
    throw RunError(
        "SystemC can elaborate only once per process; run each simulation in its own process");
  g_elaborated = true;
  ::setenv("SC_COPYRIGHT_MESSAGE", "DISABLE", 1);
  Top top("rosguard", config);
  return top.run();
}

std::string sc_version_string() {
  return SC_VERSION;
}

IsolationResult isolation_of(const SimReport& report, const SimPlatform& platform) {
  const JobStats& j = report.rt_jobs.at(0).at(0);
  IsolationResult r;
  r.time_us = static_cast<double>(j.end - j.start) / 1e3;
  // No cycle counted (an empty job): IPC and bandwidth are not applicable, not zero.
  r.ipc = j.cycles > 0 ? j.instructions / j.cycles : not_applicable();
  r.mbps = j.cycles > 0
               ? eq1_mbps(platform.line_bytes, platform.freq_mhz * 1e6, j.l3_accesses, j.cycles)
               : not_applicable();
  return r;
}

}  // namespace rosguard::sim

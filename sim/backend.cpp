#include "backend.h"

#include <cmath>
#include <iomanip>
#include <sstream>

#include "core/error.h"
#include "regulator/setup.h"

namespace rosguard::sim {
namespace {

TimeNs us_to_ns(double us) {
  return static_cast<TimeNs>(std::llround(us * 1e3));
}

// The workload's profile on this platform: from the platform's model of its hw kernel when there
// is one, else its "sim" section (workload/profile.h: profile_for).
WorkloadProfile profile_of(const Scenario& s, const SimPlatform& platform, const WorkloadInfo& w,
                           const std::string& node) {
  const bool inline_doc = w.origin == "inline";
  try {
    return profile_for(w, platform, inline_doc ? s.file : w.origin,
                       inline_doc ? node + "/workload/sim" : "/sim");
  } catch (const InputError& e) {
    if (inline_doc) throw;
    throw InputError(
        s.file, node + "/workload",
        "workload '" + w.name + "' (" + w.origin + "): " + e.json_path() + ": " + e.message());
  }
}

std::string us_text(double us) {
  std::ostringstream o;
  o << std::setprecision(3) << us;
  return o.str();
}

SimPlatform platform_of(const Scenario& s) {
  try {
    return parse_sim_platform(s.platform);
  } catch (const InputError& e) {
    throw InputError(s.file, "/platform",
                     "platform '" + s.platform.name + "' (" + s.platform.origin +
                         ") cannot run on the sim backend: " + e.json_path() + ": " + e.message());
  }
}

// What the model cannot do, refused before it runs: a point longer than the simulated time the
// sim backend allows one run, and external sampling faster than the controller can read.
void check_feasible(const Scenario& s, const SimPlatform& platform) {
  const double limit_s = static_cast<double>(kRunLimitNs) / static_cast<double>(kNsPerS);
  if (const auto need_s = min_simulated_seconds(s); need_s && *need_s > limit_s) {
    const std::string at = s.nodes.rt.empty()             ? "/nodes/nrt/0/workload"
                           : s.nodes.rt[0].iterations > 1 ? "/nodes/rt/0/iterations"
                                                          : "/nodes/rt/0/workload";
    throw InputError(s.file, at,
                     "this point needs at least " + std::to_string(std::llround(*need_s)) +
                         " s of simulated time (estimate: instructions / (base IPC x frequency) "
                         "per job, times the jobs), more than the " +
                         std::to_string(std::llround(limit_s)) +
                         " s the sim backend simulates one run; use fewer iterations or a "
                         "shorter workload");
  }
  const RegulationSpec& r = s.regulation;
  const bool samples = !s.nodes.nrt.empty();
  if (samples && r.sampling == Sampling::Overflow && !platform.costs.overflow_irq)
    throw InputError(s.file, "/regulation/sampling",
                     "overflow sampling needs the interrupt latency of platform " + platform.name +
                         " (" + platform.origin +
                         "): it has no costs.overflow_irq_us, from a PMU overflow to the throttle "
                         "taking hold; add it (with its source) or sample otherwise");
  if (samples && r.sampling == Sampling::Mmio) {
    if (!platform.costs.mmio_poll)
      throw InputError(s.file, "/regulation/sampling",
                       "mmio sampling needs the cost of polling a core through its debug "
                       "registers on platform " +
                           platform.name + " (" + platform.origin +
                           "): it has no costs.mmio_poll_us; add it (with its source) or sample "
                           "otherwise");
    const double poll_us =
        platform.costs.mmio_poll->upper_bound() * static_cast<double>(s.nodes.nrt.size());
    if (static_cast<double>(r.sampling_period_us) < poll_us)
      throw InputError(s.file, "/regulation/sampling_period_us",
                       "mmio sampling every " + std::to_string(r.sampling_period_us) +
                           " us cannot keep up: polling " + std::to_string(s.nodes.nrt.size()) +
                           " nRT core(s) through their debug registers takes up to " +
                           us_text(poll_us) + " us on platform " + platform.name +
                           "; use a longer period");
  }
  if (r.sampling == Sampling::External && !s.nodes.nrt.empty()) {
    const double read_us =
        platform.costs.external_read.upper_bound() * static_cast<double>(s.nodes.nrt.size());
    if (static_cast<double>(r.sampling_period_us) <= read_us)
      throw InputError(s.file, "/regulation/sampling_period_us",
                       "external sampling every " + std::to_string(r.sampling_period_us) +
                           " us cannot keep up: the controller reads the counters of " +
                           std::to_string(s.nodes.nrt.size()) + " nRT core(s), which takes up to " +
                           std::to_string(static_cast<int>(std::ceil(read_us))) +
                           " us on platform " + platform.name +
                           ", so regulation would never see the usage in time; use a longer "
                           "period");
  }
}

RunConfig base_config(const Scenario& s, std::uint64_t seed) {
  RunConfig cfg;
  cfg.platform = platform_of(s);
  cfg.quantum_ns = std::max<TimeNs>(1, us_to_ns(s.sim.quantum_us));
  cfg.seed = seed;
  cfg.controller_core = s.nodes.controller_core;
  cfg.regulation.metric = s.regulation.metric;
  return cfg;
}

void record_facts(RunContext& ctx, const RunConfig& cfg) {
  ctx.fact("sim_model", "SystemC " + std::string(sc_version_string()) +
                            "; memory model and command chain: sim/README.md");
  ctx.fact("sim_platform", cfg.platform.name + " (" + cfg.platform.origin + ")");
}

}  // namespace

RunConfig isolation_config(const Scenario& s, const WorkloadInfo& workload, int core,
                           std::uint64_t seed) {
  RunConfig cfg = base_config(s, seed);
  cfg.isolation = true;
  RtSpec r;
  r.name = workload.name;
  r.core = core;
  r.profile = profile_of(s, cfg.platform, workload, "/nodes");
  cfg.rt.push_back(std::move(r));
  return cfg;
}

RunConfig point_config(const Scenario& s, RegulationSetup regulation, std::uint64_t seed) {
  RunConfig cfg = base_config(s, seed);
  for (std::size_t i = 0; i < s.nodes.rt.size(); ++i) {
    const RtNodeSpec& n = s.nodes.rt[i];
    RtSpec r;
    r.name = n.name;
    r.core = n.core;
    r.profile = profile_of(s, cfg.platform, n.workload, "/nodes/rt/" + std::to_string(i));
    r.iterations = n.iterations;
    r.period_ns = n.period_ns();
    cfg.rt.push_back(std::move(r));
  }
  for (std::size_t i = 0; i < s.nodes.nrt.size(); ++i) {
    const NrtNodeSpec& n = s.nodes.nrt[i];
    NrtSpec r;
    r.name = n.name;
    r.core = n.core;
    r.profile = profile_of(s, cfg.platform, n.workload, "/nodes/nrt/" + std::to_string(i));
    r.loop = n.mode == NrtMode::Loop;
    cfg.nrt.push_back(std::move(r));
  }
  cfg.regulation = std::move(regulation);
  return cfg;
}

void SimBackend::validate(const Scenario& s) const {
  const SimPlatform platform = platform_of(s);
  for (std::size_t i = 0; i < s.nodes.rt.size(); ++i)
    profile_of(s, platform, s.nodes.rt[i].workload, "/nodes/rt/" + std::to_string(i));
  for (std::size_t i = 0; i < s.nodes.nrt.size(); ++i)
    profile_of(s, platform, s.nodes.nrt[i].workload, "/nodes/nrt/" + std::to_string(i));

  const RegulationSpec& r = s.regulation;
  const bool samples = regulation_setup(s, policies_).regulates() && !s.nodes.nrt.empty();
  if (samples && r.sampling == Sampling::Self) {
    // On average: a rare long sample (a measured cost distribution keeps its largest sample as
    // its bound) only delays the next one, which SampleSchedule owes once.
    const double cost_us = platform.costs.pmc_callback.mean() + platform.costs.publish.mean();
    if (static_cast<double>(r.sampling_period_us) <= cost_us)
      throw InputError(s.file, "/regulation/sampling_period_us",
                       "self-sampling every " + std::to_string(r.sampling_period_us) +
                           " us leaves the nRT node no time for its work: one sample costs " +
                           std::to_string(static_cast<int>(std::ceil(cost_us))) +
                           " us on average on platform " + platform.name +
                           " (PMC callback + publishing); use a longer period or external "
                           "sampling");
  }
  check_feasible(s, platform);
}

IsolationResult SimBackend::isolation(const Scenario& s, const WorkloadInfo& workload, int core,
                                      std::uint64_t seed, RunContext& ctx) {
  RunConfig cfg = isolation_config(s, workload, core, seed);
  cfg.stop_requested = [&ctx] { return ctx.stop_requested(); };
  record_facts(ctx, cfg);
  const SimReport rep = simulate(cfg);
  return isolation_of(rep, cfg.platform);
}

PointOutcome SimBackend::run_point(const Scenario& s, const Baselines& baselines, int rep,
                                   std::uint64_t seed, RunContext& ctx) {
  (void)rep;  // the seed already differs per repetition
  RunConfig cfg = point_config(s, regulation_setup(s, policies_, &baselines), seed);
  cfg.trace = ctx.trace();
  cfg.stop_requested = [&ctx] { return ctx.stop_requested(); };
  record_facts(ctx, cfg);
  SimReport report = simulate(cfg);
  report.outcome.sampling = RanSampling{cfg.regulation.sampling, cfg.regulation.sampling_period_ns};
  return std::move(report.outcome);
}

}  // namespace rosguard::sim

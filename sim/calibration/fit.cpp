#include "calibration/fit.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <future>
#include <limits>
#include <optional>
#include <set>
#include <unsupported/Eigen/NonLinearOptimization>

#include "core/error.h"
#include "platform/contention.h"
#include "results/results.h"
#include "workload/profile.h"

namespace rosguard::calibration {
namespace {

using nlohmann::json;
using sim::SimPlatform;

const char* const kKernels[] = {"bandwidth_read", "bandwidth_write", "latency"};

bool known_kernel(const std::string& k) {
  return std::find(std::begin(kKernels), std::end(kKernels), k) != std::end(kKernels);
}

// Where a working set lives on `host`, for a kernel that streams through it cyclically.
enum class Level { L1, L2, L3, Dram };

Level level_of(double ws_kb, const HostFacts& h) {
  if (h.l1d_kb > 0 && ws_kb <= h.l1d_kb) return Level::L1;
  if (ws_kb <= h.l2_kb) return Level::L2;
  if (ws_kb <= h.l3_kb_per_cluster) return Level::L3;
  return Level::Dram;
}

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

std::string label_of(const KernelRun& r) {
  std::string s = r.kernel + " " + fmt("%g", r.working_set_kb) + " KB";
  for (const auto& c : r.corunners)
    s += " + " + c.kernel + " " + fmt("%g", c.working_set_kb) + " KB";
  return s;
}

double geomean(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v)
    s += std::log(x);
  return std::exp(s / static_cast<double>(v.size()));
}

// Traffic of one line of `kernel` beyond the L2, in L3 lines (bandwidth_write: refill and
// write-back), as kernel_profile() models it.
double lines_moved(const std::string& kernel) {
  return kernel == "bandwidth_write" ? 2.0 : 1.0;
}

double mbps_of(double lines_per_ns) {
  return lines_per_ns * 64.0 * 1e9 / 1048576.0;
}

const char* status_text(int s) {
  using namespace Eigen::LevenbergMarquardtSpace;
  switch (static_cast<Status>(s)) {
    case NotStarted:
      return "not started";
    case Running:
      return "running";
    case ImproperInputParameters:
      return "improper input parameters";
    case RelativeReductionTooSmall:
      return "converged (relative reduction below ftol)";
    case RelativeErrorTooSmall:
      return "converged (relative step below xtol)";
    case RelativeErrorAndReductionTooSmall:
      return "converged (reduction and step below tolerance)";
    case CosinusTooSmall:
      return "converged (residuals orthogonal to the Jacobian, gtol)";
    case TooManyFunctionEvaluation:
      return "too many function evaluations";
    case FtolTooSmall:
      return "converged to machine precision (no further reduction possible)";
    case XtolTooSmall:
      return "converged to machine precision (no further step possible)";
    case GtolTooSmall:
      return "converged to machine precision (gradient orthogonal)";
    case UserAsked:
      return "stopped";
  }
  return "unknown";
}

bool converged_status(int s) {
  using namespace Eigen::LevenbergMarquardtSpace;
  switch (static_cast<Status>(s)) {
    case RelativeReductionTooSmall:
    case RelativeErrorTooSmall:
    case RelativeErrorAndReductionTooSmall:
    case CosinusTooSmall:
    case FtolTooSmall:
    case XtolTooSmall:
    case GtolTooSmall:
      return true;
    default:
      return false;
  }
}

// A prior of one parameter: lognormal, median `median`, `log_sd` the standard deviation of the
// logarithm (ln 2: a factor 2 either way at one standard deviation), and where it comes from.
struct Prior {
  double median = 1.0;
  double log_sd = 1.0;
  std::string source;
};

// One free parameter: where it lives in the platform, what identifies it, and its prior.
struct Slot {
  std::string name;
  std::function<double&(SimPlatform&)> ref;
  std::string how;
  Prior prior;
  // The end of its range where the platform schema sets one (hold_beyond_range).
  double upper = std::numeric_limits<double>::infinity();
};

// A run's weight in the fit: kCvFloor / max(cv, kCvFloor). Runs whose repetitions scatter
// (another tenant's traffic, a cache shared with the host) count less, in proportion to their
// coefficient of variation; below the floor (the repeatability of a 20 ms window here, about
// 2 %) every run counts the same.
constexpr double kCvFloor = 0.02;
double weight_of(const KernelRun& run) {
  return kCvFloor / std::max(std::isfinite(run.cv) ? run.cv : 1.0, kCvFloor);
}

// The residuals of the MAP fit as a function of the log parameters, for Eigen's LM (minpack
// interface: operator() and df()): first weight * log(predicted / measured) of each used run,
// then sigma * (x - log prior median) / prior log_sd of each parameter.
struct Residuals {
  using Scalar = double;
  enum { InputsAtCompileTime = Eigen::Dynamic, ValuesAtCompileTime = Eigen::Dynamic };
  using InputType = Eigen::VectorXd;
  using ValueType = Eigen::VectorXd;
  using JacobianType = Eigen::MatrixXd;

  const SimPlatform* base;
  const std::vector<Slot>* slots;
  const std::vector<const KernelRun*>* runs;
  double sigma = 1.0;  // the runs' weighted residual standard deviation
  mutable int evaluations = 0;

  int inputs() const { return static_cast<int>(slots->size()); }
  int values() const { return static_cast<int>(runs->size() + slots->size()); }

  SimPlatform platform_at(const Eigen::VectorXd& x) const {
    SimPlatform p = *base;
    for (std::size_t i = 0; i < slots->size(); ++i)
      (*slots)[i].ref(p) = std::exp(x[static_cast<Eigen::Index>(i)]);
    return p;
  }

  int operator()(const Eigen::VectorXd& x, Eigen::VectorXd& f) const {
    ++evaluations;
    const SimPlatform p = platform_at(x);
    for (std::size_t i = 0; i < runs->size(); ++i) {
      const double pred = predict_ns_per_line(p, *(*runs)[i]);
      // A non-finite prediction (a parameter far out of range) counts as a large miss.
      f[static_cast<Eigen::Index>(i)] =
          weight_of(*(*runs)[i]) *
          (std::isfinite(pred) && pred > 0 ? std::log(pred / (*runs)[i]->ns_per_line) : 10.0);
    }
    for (std::size_t j = 0; j < slots->size(); ++j) {
      const Prior& pr = (*slots)[j].prior;
      f[static_cast<Eigen::Index>(runs->size() + j)] =
          sigma * (x[static_cast<Eigen::Index>(j)] - std::log(pr.median)) / pr.log_sd;
    }
    return 0;
  }

  // The runs' part of the objective at x.
  double data_ssr(const Eigen::VectorXd& x) const {
    Eigen::VectorXd f(values());
    (*this)(x, f);
    return f.head(static_cast<Eigen::Index>(runs->size())).squaredNorm();
  }

  // Central differences with a fixed step on the log scale (a relative step of 1e-5 in each
  // parameter): the memory model's fixed point is solved to ~1e-13, so the derivative error
  // stays near 1e-8, far below what minpack's default forward step would give.
  int df(const Eigen::VectorXd& x, Eigen::MatrixXd& jac) const {
    constexpr double h = 1e-5;
    Eigen::VectorXd fp(values()), fm(values());
    Eigen::VectorXd xp = x;
    for (Eigen::Index j = 0; j < x.size(); ++j) {
      xp[j] = x[j] + h;
      (*this)(xp, fp);
      xp[j] = x[j] - h;
      (*this)(xp, fm);
      xp[j] = x[j];
      jac.col(j) = (fp - fm) / (2.0 * h);
    }
    return 0;
  }
};

double round_sig(double v, int digits) {
  if (v == 0.0 || !std::isfinite(v)) return v;
  const double mag = std::pow(10.0, std::floor(std::log10(std::abs(v))) - (digits - 1));
  return std::round(v / mag) * mag;
}

}  // namespace

SimPlatform model_platform(const HostFacts& host) {
  SimPlatform p;
  p.name = host.hostname.empty() ? "host" : host.hostname;
  p.origin = "rosguard calibrate";
  p.clusters = std::max(1, host.clusters);
  p.cores_per_cluster = std::max(1, host.cores_per_cluster);
  p.freq_mhz = host.freq_mhz;
  p.line_bytes = static_cast<std::uint32_t>(host.line_bytes);
  p.l2_kb = host.l2_kb;
  p.l3.capacity_kb = host.l3_kb_per_cluster;
  return p;
}

double predict_ns_per_line(const SimPlatform& platform, const KernelRun& run) {
  if (static_cast<int>(run.corunners.size()) >= platform.cores())
    throw RunError("calibration run '" + label_of(run) + "' has " +
                   std::to_string(run.corunners.size()) + " co-runners, but " + platform.name +
                   " has only " + std::to_string(platform.cores()) + " cores");
  const auto profile = [&](const std::string& kernel, double ws_kb) {
    const auto it = platform.kernels.find(kernel);
    if (it == platform.kernels.end())
      throw RunError("no model of kernel '" + kernel + "' to predict '" + label_of(run) + "'");
    return sim::kernel_profile(kernel, kernel, it->second, ws_kb, 1.0, platform);
  };
  // All profiles first: the demands point into them.
  std::vector<sim::WorkloadProfile> profiles;
  profiles.reserve(run.corunners.size() + 1);
  profiles.push_back(profile(run.kernel, run.working_set_kb));
  for (const auto& c : run.corunners)
    profiles.push_back(profile(c.kernel, c.working_set_kb));
  // The measured kernel on core 0, co-runner k on core k + 1, each in that core's cluster.
  std::vector<sim::CoreDemand> demands;
  for (int core = 0; const auto& w : profiles)
    demands.push_back({platform.cluster_of(core++), &w.phases[0], &w, true, &w.phases[0]});
  const sim::ContentionModel model(platform);
  const sim::MemoryState st = model.solve(demands);
  const sim::CoreRates r = model.rates(profiles[0].phases[0], st.l3_hit[0], 0, st, st.slc_hit[0]);
  return 1.0 / r.inst_per_ns;  // one instruction per line
}

namespace {

// The samples sorted and their summary (count, range, median, 90th percentile), no distribution
// yet. Throws RunError without samples.
CostFit summarize(std::vector<double>& samples) {
  if (samples.empty()) throw RunError("a cost distribution needs samples");
  std::sort(samples.begin(), samples.end());
  CostFit c;
  c.samples = samples.size();
  c.min_us = samples.front();
  c.max_us = samples.back();
  c.median_us = percentile(samples, 50.0);
  c.p90_us = percentile(samples, 90.0);
  return c;
}

}  // namespace

CostFit fit_cost(std::vector<double> samples) {
  CostFit c = summarize(samples);
  if (c.max_us <= c.min_us) {
    c.distribution = {{"dist", "constant"}, {"value_us", round_sig(c.min_us, 4)}};
    return c;
  }
  // A shifted lognormal loc + m exp(sigma N(0,1)) through the 10th, 50th and 90th percentiles:
  // (q90 - loc)(q10 - loc) = (q50 - loc)^2 gives the location, which must lie in [0, min].
  constexpr double kZ90 = 1.2815515655446004;  // standard normal 90th percentile
  const double q10 = percentile(samples, 10.0);
  const double skew = c.p90_us + q10 - 2.0 * c.median_us;
  double loc = skew > 0 ? (c.p90_us * q10 - c.median_us * c.median_us) / skew : -1.0;
  if (skew > 0) loc = std::clamp(loc, 0.0, c.min_us);
  const double sigma = std::log((c.p90_us - loc) / (c.median_us - loc)) / kZ90;
  if (skew > 0 && c.median_us > loc && std::isfinite(sigma) && sigma > 0) {
    c.distribution = {{"dist", "lognormal"},
                      {"min_us", round_sig(loc, 4)},
                      {"median_us", round_sig(c.median_us, 4)},
                      {"sigma", round_sig(sigma, 3)},
                      {"max_us", round_sig(c.max_us, 4)}};
    // Rounding must keep the median above the location.
    if (c.distribution["median_us"].get<double>() <= c.distribution["min_us"].get<double>())
      c.distribution["min_us"] = loc;
    return c;
  }
  // Not right-skewed: a normal through the same percentiles (mean the median, sd from the 10th
  // to the 90th), truncated to the samples' range. Not the samples' mean and sd: one sample of a
  // wake-up that RT throttling delayed by 50 ms among 500 of 15-25 us made them 71 and 1580 us,
  // and the sim's controller then woke so late, so often, that the nRT core never ran
  // (make validate, 2026-11-28).
  const double sd = (c.p90_us - q10) / (2.0 * kZ90);
  c.distribution = {{"dist", "normal"},
                    {"mean_us", round_sig(c.median_us, 4)},
                    {"sd_us", round_sig(sd, 3)},
                    {"min_us", c.min_us},
                    {"max_us", c.max_us}};
  return c;
}

CostFit fit_mean_cost(std::vector<double> samples) {
  CostFit c = summarize(samples);
  c.distribution = {{"dist", "constant"}, {"value_us", round_sig(std::max(0.0, c.median_us), 4)}};
  return c;
}

namespace {

const double kLn2 = std::log(2.0), kLn3 = std::log(3.0), kLn4 = std::log(4.0);
// dram.writeback_weight's range in the platform schema, (0, 4]. A fit on the Xeon VM of
// 2026-11-28 went to 4.92 (its co-runs beyond the L3 showed no DRAM contention; the writers'
// co-runs slowed the reader through something else) and wrote a model the schema refuses.
constexpr double kMaxWritebackWeight = 4.0;

// Typical values for what a host's runs may not show at all (no run beyond the LLC, no co-run at
// a level). Wide on purpose: the data overrule them wherever they say anything.
constexpr double kTypicalDramNs = 90.0;  // idle load-to-use latency of DRAM
constexpr double kTypicalMlp = 10.0;     // a core's L1D misses in flight
constexpr double kTypicalL3MbpsCore = 20000.0;
constexpr double kTypicalDramMbps = 51200.0;  // two DDR4-3200 channels (2 x 25.6 GB/s)
const char* const kTypicalDramSource =
    "typical idle DRAM load-to-use latency (about 70-130 ns on current servers, desktops and "
    "SoCs, e.g. Intel MLC idle latencies) less the measured L3 latency";
const char* const kTypicalMlpSource =
    "typical misses in flight of a streaming out-of-order core (its L1D miss buffers: 10-16 on "
    "Intel cores since Skylake, 22-24 on AMD Zen, 12-20 on Arm Cortex-A7x), a factor 3 either way";

// The runs the model covers, and what they can identify.
struct RunSelection {
  std::vector<const KernelRun*> used;
  std::map<std::string, std::map<Level, std::vector<double>>> iso;  // kernel -> level -> ns
  // Co-runner counts of the bandwidth-latency curves: within the L3 (co-runners beyond the L2)
  // and beyond it (co-runners beyond the L3).
  std::set<std::size_t> l3_counts, dram_counts;
  std::map<std::string, bool> beyond_l3;  // kernel measured beyond the L3 (iso or co-run)
  bool dram_writer_corun = false;         // a co-run beyond the L3 in which a kernel there writes
};

// Sorts the runs into those the model covers and those it does not: each in rep.runs, the latter
// with the reason.
RunSelection select_runs(const Measurements& m, const SimPlatform& base, FitReport& rep) {
  const HostFacts& host = m.host;
  RunSelection sel;
  const auto state = calibration::suite_state(m);
  // The probes around a run's block that are not in the suite's state, described; empty when
  // they all are (or it has none).
  const auto off_state = [&](const KernelRun& r) {
    std::string off;
    for (const int at : r.probes)
      if (const auto& p = m.contention.at(static_cast<std::size_t>(at));
          state && !calibration::same_contention_state(*state, p))
        off += (off.empty() ? "" : ", ") + fmt("%.2fx", p.ratio) + " " + p.when;
    return off;
  };
  for (std::size_t i = 0; i < m.runs.size(); ++i) {
    const KernelRun& r = m.runs[i];
    FittedRun fr;
    fr.index = i;
    fr.label = label_of(r);
    fr.measured_ns = r.ns_per_line;
    bool ok = known_kernel(r.kernel) && r.ns_per_line > 0;
    for (const auto& c : r.corunners)
      ok = ok && known_kernel(c.kernel);
    const Level lv = level_of(r.working_set_kb, host);
    if (!ok) {
      fr.note =
          "not modelled: a kernel without a model (the fit knows bandwidth_read, "
          "bandwidth_write, latency)";
    } else if (static_cast<int>(r.corunners.size()) >= base.cores()) {
      fr.note = "not modelled: more co-runners than the model has other cores";
    } else if (lv == Level::L1) {
      fr.note = "not modelled: the working set fits the L1d (the model starts at the L2)";
    } else if (const std::string off = off_state(r); !off.empty()) {
      fr.note = "left out: measured in another DRAM-interference state than the suite's (" +
                calibration::describe(*state) + "): probe " + off;
    } else {
      fr.used = true;
      sel.used.push_back(&r);
      if (r.corunners.empty()) sel.iso[r.kernel][lv].push_back(r.ns_per_line);
      if (lv == Level::Dram) sel.beyond_l3[r.kernel] = true;
      std::size_t co_l3 = 0, co_dram = 0;
      bool writes_beyond = lv == Level::Dram && lines_moved(r.kernel) > 1.0;
      for (int core = 1; const auto& c : r.corunners) {
        // Only a co-runner in the measured core's cluster shares its L3.
        co_l3 += c.working_set_kb > host.l2_kb && base.cluster_of(core++) == 0 ? 1 : 0;
        const bool beyond = c.working_set_kb > host.l3_kb_per_cluster;
        co_dram += beyond ? 1 : 0;
        writes_beyond = writes_beyond || (beyond && lines_moved(c.kernel) > 1.0);
      }
      if (lv == Level::L3 && co_l3 > 0) sel.l3_counts.insert(co_l3);
      if (lv == Level::Dram && co_dram > 0) sel.dram_counts.insert(co_dram);
      sel.dram_writer_corun =
          sel.dram_writer_corun || (lv == Level::Dram && co_dram > 0 && writes_beyond);
    }
    rep.runs.push_back(fr);
  }
  return sel;
}

// What the data must contain: each kernel's own speed within the L2 and the L3 (no prior can
// stand in for those); every gap is named.
void require_own_speeds(const RunSelection& sel, const HostFacts& host) {
  std::vector<std::string> missing;
  const auto l2s = fmt("%g KB", host.l2_kb), l3s = fmt("%g KB", host.l3_kb_per_cluster);
  for (const char* need : {"bandwidth_read", "latency"})
    if (!sel.iso.count(need)) missing.push_back(std::string("isolation runs of ") + need);
  for (const auto& [k, levels] : sel.iso) {
    if (!levels.count(Level::L2))
      missing.push_back("an isolation run of " + k + " within the L2 (<= " + l2s + ")");
    if (!levels.count(Level::L3))
      missing.push_back("an isolation run of " + k + " within the L3 (" + l2s + " .. " + l3s + ")");
  }
  if (missing.empty()) return;
  std::string msg = "calibration: insufficient measurements to fit the memory model; missing: ";
  for (std::size_t i = 0; i < missing.size(); ++i)
    msg += (i ? "; " : "") + missing[i];
  throw RunError(msg);
}

// What the data do not show directly: named here; what then rests on its prior is named per
// parameter by report_parameters (runs whose sets overflow the L3 together may still show it).
void note_unseen(const RunSelection& sel, const HostFacts& host, FitReport& rep) {
  const auto l3s = fmt("%g KB", host.l3_kb_per_cluster);
  for (const auto& [k, levels] : sel.iso)
    if (k != "latency" && !sel.beyond_l3.count(k))
      rep.notes.push_back("no run of " + k + " beyond the L3 (> " + l3s + "): kernels." + k +
                          ".mlp is seen only where sets overflow the L3 "
                          "together, else its prior stands");
  if (sel.iso.at("latency").count(Level::Dram) == 0)
    rep.notes.push_back("no isolation run of latency beyond the L3 (> " + l3s +
                        "): dram.latency_ns is seen only where sets overflow the L3 together, "
                        "else its prior stands");
  if (sel.l3_counts.empty())
    rep.notes.push_back(
        "no co-run within the L3 (a kernel within the L3 with a co-runner beyond the L2): "
        "l3.queue_ns and l3.bandwidth_mbps rest on their priors");
  if (sel.dram_counts.empty())
    rep.notes.push_back(
        "no co-run beyond the L3 (a kernel and a co-runner beyond the L3): dram.queue_ns and "
        "dram.bandwidth_mbps are seen only where sets overflow the L3 together, else their "
        "priors stand");
}

// The priors that do not follow from one level's latency alone.
struct Priors {
  Prior dram_latency;
  std::map<std::string, Prior> mlp;  // kernel -> its misses in flight (not the latency kernel)
  Prior l3_bandwidth, dram_bandwidth;
};

// The DRAM latency's prior and each streaming kernel's mlp prior: from the runs beyond the L3
// where there are some, else from typical values. Sets base's values to the priors' medians.
Priors latency_priors(const RunSelection& sel, SimPlatform& base) {
  Priors pr;
  const double lat_l3 = base.l3.latency_ns;
  const auto& latency_runs = sel.iso.at("latency");
  if (const auto d = latency_runs.find(Level::Dram); d != latency_runs.end()) {
    const double lat_dram = geomean(d->second);
    pr.dram_latency = {std::max(lat_dram - lat_l3, 0.5 * lat_dram), kLn2,
                       "the latency kernel's isolation runs beyond the L3 less its L3 latency, "
                       "a factor 2 either way"};
  } else {
    pr.dram_latency = {std::max(kTypicalDramNs - lat_l3, 0.5 * kTypicalDramNs), kLn2,
                       kTypicalDramSource + std::string(", a factor 2 either way")};
  }
  base.dram.latency_ns = pr.dram_latency.median;
  for (auto& [k, km] : base.kernels) {
    km.mlp = 1.0;
    if (k == "latency") continue;
    const auto d = sel.iso.at(k).find(Level::Dram);
    const double extra = d == sel.iso.at(k).end() ? 0.0 : geomean(d->second) - km.ns_per_line_l3;
    if (extra > 0)
      pr.mlp[k] = {std::clamp(base.dram.latency_ns / extra, 1.0, 64.0), kLn3,
                   "the DRAM latency over the extra ns per line of " + k +
                       "'s isolation runs beyond the L3, a factor 3 either way"};
    else
      pr.mlp[k] = {kTypicalMlp, kLn3, kTypicalMlpSource};
    km.mlp = pr.mlp[k].median;
  }
  return pr;
}

// Bandwidths: the largest traffic a run shows at each level (every core beyond the L2 in the
// measured core's cluster, or beyond the L3, at the measured kernel's rate) is a floor; twice it,
// a factor 4 either way.
void bandwidth_priors(const RunSelection& sel, const HostFacts& host, const SimPlatform& base,
                      Priors& pr) {
  double l3_peak = 0.0, dram_peak = 0.0;
  for (const KernelRun* r : sel.used) {
    const double rate = lines_moved(r->kernel) / r->ns_per_line;
    double l3_cores = r->working_set_kb > host.l2_kb ? 1.0 : 0.0;
    double dram_cores = r->working_set_kb > host.l3_kb_per_cluster ? 1.0 : 0.0;
    for (int core = 1; const auto& c : r->corunners) {
      l3_cores += c.working_set_kb > host.l2_kb && base.cluster_of(core++) == 0 ? 1.0 : 0.0;
      dram_cores += c.working_set_kb > host.l3_kb_per_cluster ? 1.0 : 0.0;
    }
    l3_peak = std::max(l3_peak, mbps_of(rate * l3_cores));
    dram_peak = std::max(dram_peak, mbps_of(rate * dram_cores));
  }
  const auto bandwidth_prior = [](double peak, double typical, const std::string& typical_source) {
    if (peak > 0)
      return Prior{2.0 * peak, kLn4,
                   "twice the largest traffic the runs moved through it (" + fmt("%.0f", peak) +
                       " MB/s: a floor), a factor 4 either way"};
    return Prior{typical, kLn4, typical_source + ", a factor 4 either way"};
  };
  pr.l3_bandwidth =
      bandwidth_prior(l3_peak, kTypicalL3MbpsCore * base.cores_per_cluster,
                      "typical L3 bandwidth of 20 GB/s per core of the cluster (no run reached "
                      "the L3)");
  pr.dram_bandwidth =
      bandwidth_prior(dram_peak, kTypicalDramMbps,
                      "typical DRAM bandwidth of two DDR4-3200 channels, 51.2 GB/s (no run "
                      "reached DRAM)");
}

// The starting point: the kernels' own speeds from their isolation runs, the rest at its prior's
// median (a queue at its level's unloaded latency); the priors.
Priors starting_point(const RunSelection& sel, const HostFacts& host, const FitOptions& opt,
                      SimPlatform& base) {
  for (const auto& [k, levels] : sel.iso) {
    sim::KernelModel km;
    km.ns_per_line_l2 = geomean(levels.at(Level::L2));
    km.ns_per_line_l3 = geomean(levels.at(Level::L3));
    base.kernels[k] = km;
  }
  base.l3.latency_ns = base.kernels.at("latency").ns_per_line_l3;
  Priors pr = latency_priors(sel, base);
  bandwidth_priors(sel, host, base, pr);
  base.l3.bandwidth_mbps = pr.l3_bandwidth.median;
  base.l3.queue_ns = base.l3.latency_ns;
  base.dram.bandwidth_mbps = pr.dram_bandwidth.median;
  base.dram.queue_ns = base.dram.latency_ns;
  base.mshr.per_core = opt.mshr_per_core;
  base.mshr.per_cluster = opt.mshr_per_cluster;
  return pr;
}

// The model's parameters: those the fit estimates, and those it holds (fixed by the caller, not
// identified by the runs, or derived).
struct Parameters {
  std::vector<Slot> free;
  std::vector<FittedParameter> held;
};

// The caller's value of `name` (FitOptions::fixed), if it names one.
std::optional<double> fixed_value(const FitOptions& opt, const std::string& name) {
  const auto it = opt.fixed.find(name);
  if (it == opt.fixed.end()) return std::nullopt;
  if (!(it->second > 0))
    throw RunError("calibration: fixed value of " + name + " must be positive");
  return it->second;
}

// A parameter the fit does not estimate, put into base: the caller's value where it fixes one,
// else `value`, held for the reason `why`.
void hold(const FitOptions& opt, SimPlatform& base, Parameters& params, const std::string& name,
          const std::function<double&(SimPlatform&)>& ref, double value, const std::string& why) {
  FittedParameter p;
  p.name = name;
  const auto fixed = fixed_value(opt, name);
  p.value = fixed.value_or(value);
  p.how = fixed ? "fixed by the caller" : why;
  ref(base) = p.value;
  params.held.push_back(p);
}

// The parameters the runs identify, each free unless the caller fixes it (then held at the
// caller's value in base).
Parameters free_parameters(const RunSelection& sel, const Priors& pr, const FitOptions& opt,
                           SimPlatform& base, FitReport& rep) {
  Parameters params;
  const auto add = [&](const std::string& name, std::function<double&(SimPlatform&)> ref,
                       const std::string& how, Prior prior,
                       double upper = std::numeric_limits<double>::infinity()) {
    if (const auto v = fixed_value(opt, name)) {
      hold(opt, base, params, name, ref, *v, "");
      rep.notes.push_back(name + " fixed by the caller at " + fmt("%g", *v));
      return;
    }
    params.free.push_back({name, std::move(ref), how, std::move(prior), upper});
  };
  for (const auto& [k, km] : base.kernels) {
    const std::string kk = k;
    add("kernels." + k + ".ns_per_line_l2",
        [kk](SimPlatform& p) -> double& { return p.kernels.at(kk).ns_per_line_l2; },
        "isolation runs of " + k + " within the L2",
        {km.ns_per_line_l2, kLn4, "the isolation runs within the L2, a factor 4 either way"});
    add("kernels." + k + ".ns_per_line_l3",
        [kk](SimPlatform& p) -> double& { return p.kernels.at(kk).ns_per_line_l3; },
        "isolation runs of " + k + " within the L3",
        {km.ns_per_line_l3, kLn4, "the isolation runs within the L3, a factor 4 either way"});
    if (k != "latency")
      add(
          "kernels." + k + ".mlp", [kk](SimPlatform& p) -> double& { return p.kernels.at(kk).mlp; },
          "runs of " + k + " beyond the L3, given the DRAM latency", pr.mlp.at(k));
  }
  // A queue's prior is its level's unloaded latency (the delay doubles at half load): with one
  // co-runner count (a 2-core cluster) the runs show how much the latency grows, not how it
  // bends, so the queue and the bandwidth trade off and the prior decides between them.
  add("l3.queue_ns", [](SimPlatform& p) -> double& { return p.l3.queue_ns; },
      "co-runs within the L3 at " + std::to_string(sel.l3_counts.size()) + " co-runner count(s)",
      {base.l3.latency_ns, kLn3,
       "the unloaded L3 latency (the delay doubles at half load), a factor 3 either way"});
  add(
      "l3.bandwidth_mbps", [](SimPlatform& p) -> double& { return p.l3.bandwidth_mbps; },
      "co-runs within the L3", pr.l3_bandwidth);
  add(
      "dram.latency_ns", [](SimPlatform& p) -> double& { return p.dram.latency_ns; },
      "the latency kernel (one load in flight) beyond the L3", pr.dram_latency);
  add("dram.queue_ns", [](SimPlatform& p) -> double& { return p.dram.queue_ns; },
      "co-runs beyond the L3 at " + std::to_string(sel.dram_counts.size()) + " co-runner count(s)",
      {base.dram.latency_ns, kLn3,
       "the unloaded DRAM latency's prior (the delay doubles at half load), a factor 3 either "
       "way"});
  add(
      "dram.bandwidth_mbps", [](SimPlatform& p) -> double& { return p.dram.bandwidth_mbps; },
      "co-runs beyond the L3", pr.dram_bandwidth);
  // A write-back's share of the DRAM's bandwidth shows only where a writer's traffic meets
  // another's there; without such a co-run it is held at 1 (a line each way).
  if (sel.dram_writer_corun) {
    add(
        "dram.writeback_weight", [](SimPlatform& p) -> double& { return p.dram.writeback_weight; },
        "co-runs beyond the L3 with a writing kernel beside a reading or writing one",
        {1.0, kLn2,
         "a write-back moves one line to DRAM as a refill moves one from it (1), a factor 2 "
         "either way (a controller that batches writes costs less, read-write turnarounds more)"},
        kMaxWritebackWeight);
  } else {
    hold(
        opt, base, params, "dram.writeback_weight",
        [](SimPlatform& p) -> double& { return p.dram.writeback_weight; }, 1.0,
        "held at 1, a line each way (not identified: no co-run beyond the L3 with a writing "
        "kernel)");
  }
  return params;
}

// The misses-in-flight bounds: the suite's runs cannot tell a kernel's mlp from the core's
// buffers (nor, with at most one co-runner count, the cluster's), so both are held where they
// do not bind unless the caller fixes them. The runs that overflow the L3 together are
// predicted by the shared-LRU model, which has no parameter. A pointer chase's mlp is 1.
void hold_unidentified(const FitOptions& opt, SimPlatform& base, Parameters& params) {
  const std::string why =
      " (not identified: the runs cannot tell a kernel's misses in flight from the buffers' "
      "bound; this value does not bind)";
  hold(
      opt, base, params, "mshr.per_core", [](SimPlatform& p) -> double& { return p.mshr.per_core; },
      base.mshr.per_core, "held at " + fmt("%g", base.mshr.per_core) + why);
  hold(
      opt, base, params, "mshr.per_cluster",
      [](SimPlatform& p) -> double& { return p.mshr.per_cluster; }, base.mshr.per_cluster,
      "held at " + fmt("%g", base.mshr.per_cluster) + why);
  FittedParameter p;
  p.name = "kernels.latency.mlp";
  p.value = 1.0;
  p.how = "fixed: a pointer chase has one load in flight";
  params.held.push_back(p);
}

std::string lm_status_message(const FitReport& rep) {
  return " (Levenberg-Marquardt status " + std::to_string(rep.lm_status) + ": " +
         rep.lm_status_text + ", " + std::to_string(rep.evaluations) + " evaluations)";
}

// The solve. MAP: the weighted log residuals of the runs and, per parameter, (log value - log
// prior median) / prior log_sd scaled by the runs' noise (sigma), so that a prior counts as one
// measurement of the parameter with that spread. sigma is the runs' residual standard deviation
// (at least the repeatability floor), re-estimated until it settles. Moves x to the solution,
// records the solver's status in rep and returns sigma^2; throws when the solver does not
// converge.
double solve_map(Residuals& fn, Eigen::VectorXd& x, const FitOptions& opt, int dof,
                 FitReport& rep) {
  Eigen::LevenbergMarquardtSpace::Status status{};
  Eigen::Index iterations = 0;
  double s2 = kCvFloor * kCvFloor;
  for (int pass = 0; pass < 4; ++pass) {
    fn.sigma = std::sqrt(s2);
    Eigen::LevenbergMarquardt<Residuals> lm(fn);
    lm.parameters.maxfev =
        opt.max_evaluations > 0 ? opt.max_evaluations : 100 * (static_cast<int>(x.size()) + 1);
    lm.parameters.ftol = 1e-12;
    lm.parameters.xtol = 1e-10;
    status = lm.minimize(x);
    iterations += lm.iter;
    if (!converged_status(static_cast<int>(status))) break;
    const double next = std::max(fn.data_ssr(x) / dof, kCvFloor * kCvFloor);
    const bool settled = std::abs(std::log(next / s2)) < 0.1;
    s2 = next;
    if (settled) break;
  }
  fn.sigma = std::sqrt(s2);
  rep.lm_status = static_cast<int>(status);
  rep.lm_status_text = status_text(rep.lm_status);
  rep.evaluations = fn.evaluations;
  rep.iterations = static_cast<int>(iterations);
  rep.converged = converged_status(rep.lm_status);
  if (!rep.converged)
    throw RunError("calibration: the fit did not converge" + lm_status_message(rep));
  return s2;
}

// solve_map from several starts, keeping the lowest MAP objective. Where a level's queue and
// bandwidth trade off, the objective can have more than one local minimum: on the AMD EPYC VM of
// 2026-11-27 LM from the priors' medians stopped at a DRAM bandwidth of 252 GB/s with a 179 ns
// queue (objective 0.20), where 60 GB/s gives 0.11. So LM also starts with each bandwidth at a
// half and a quarter of its prior median (the largest traffic the runs moved through it, and half
// of that), the rest at the medians. The objectives are compared at the first start's noise
// level (sigma weighs the priors). Throws the first start's error when no start converges.
double solve_from_starts(Residuals& fn, Eigen::VectorXd& x, const FitOptions& opt, int dof,
                         FitReport& rep) {
  std::vector<Eigen::VectorXd> starts{x};
  for (std::size_t i = 0; i < fn.slots->size(); ++i) {
    const std::string& name = (*fn.slots)[i].name;
    if (name != "l3.bandwidth_mbps" && name != "dram.bandwidth_mbps") continue;
    for (double f : {0.5, 0.25}) {
      Eigen::VectorXd y = x;
      y[static_cast<Eigen::Index>(i)] += std::log(f);
      starts.push_back(y);
    }
  }
  std::optional<RunError> first_error;
  double best_objective = std::numeric_limits<double>::infinity(), best_s2 = 0.0, sigma = -1.0;
  int iterations = 0;
  FitReport best;
  for (const Eigen::VectorXd& start : starts) {
    Eigen::VectorXd y = start;
    FitReport trial;
    double s2 = 0.0;
    try {
      s2 = solve_map(fn, y, opt, dof, trial);
    } catch (const RunError& e) {
      iterations += trial.iterations;
      if (!first_error) first_error = e;
      continue;
    }
    iterations += trial.iterations;
    if (sigma < 0) sigma = std::sqrt(s2);
    fn.sigma = sigma;
    Eigen::VectorXd f(fn.values());
    fn(y, f);
    if (f.squaredNorm() < best_objective) {
      best_objective = f.squaredNorm();
      best_s2 = s2;
      best = trial;
      x = y;
    }
  }
  if (!std::isfinite(best_objective)) throw *first_error;
  fn.sigma = std::sqrt(best_s2);
  rep.lm_status = best.lm_status;
  rep.lm_status_text = best.lm_status_text;
  rep.converged = best.converged;
  rep.evaluations = fn.evaluations;
  rep.iterations = iterations;
  return best_s2;
}

// The free parameters the fit put beyond the end of their range (Slot::upper): each is held at
// that end, with a note, and leaves `free` and x (the others keep their fitted values in x, to
// start the fit again from). Returns whether any did. An active set of one step: the objective
// stays smooth, where a bound inside it (min(exp(x), upper)) left the solver crawling along the
// kink for minutes.
bool hold_beyond_range(SimPlatform& base, Parameters& params, Eigen::VectorXd& x, FitReport& rep) {
  std::vector<Slot> free;
  std::vector<double> kept;
  for (std::size_t i = 0; i < params.free.size(); ++i) {
    const Slot& s = params.free[i];
    const double fitted = std::exp(x[static_cast<Eigen::Index>(i)]);
    if (fitted <= s.upper) {
      free.push_back(s);
      kept.push_back(x[static_cast<Eigen::Index>(i)]);
      continue;
    }
    FittedParameter p;
    p.name = s.name;
    p.value = s.upper;
    p.at_bound = true;
    p.how =
        "held at " + fmt("%g", s.upper) +
        ", the end of its range: the runs push it beyond (fitted freely: " + fmt("%.4g", fitted) +
        "), where the model cannot follow them";
    s.ref(base) = s.upper;
    rep.notes.push_back(s.name + " " + p.how);
    params.held.push_back(p);
  }
  if (free.size() == params.free.size()) return false;
  params.free = std::move(free);
  x = Eigen::Map<const Eigen::VectorXd>(kept.data(), static_cast<Eigen::Index>(kept.size()));
  return true;
}

// The residuals (runs, then priors) at the solution and the posterior covariance of the log
// parameters.
struct Posterior {
  Eigen::VectorXd residuals;
  Eigen::MatrixXd cov;
};

// Residuals and the Jacobian (runs and priors) at the solution; the posterior covariance of the
// log parameters is s^2 (J^T J)^-1, full rank through the priors' rows. Records the weighted RMS
// residual of the runs and the objective in rep.
Posterior posterior(const Residuals& fn, const Eigen::VectorXd& x, double s2, FitReport& rep) {
  const auto n = x.size();
  const auto mres = static_cast<Eigen::Index>(fn.runs->size());
  Posterior post;
  post.residuals.resize(mres + n);
  fn(x, post.residuals);
  Eigen::MatrixXd jac(mres + n, n);
  fn.df(x, jac);
  const double ssr = post.residuals.head(mres).squaredNorm();
  double sum_w2 = 0.0;
  for (const KernelRun* r : *fn.runs)
    sum_w2 += weight_of(*r) * weight_of(*r);
  rep.data_ssr = ssr;
  rep.rms_residual = std::sqrt(ssr / sum_w2);  // weighted RMS of the log ratios
  rep.objective = post.residuals.squaredNorm();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(jac, Eigen::ComputeThinV);
  const Eigen::VectorXd sv = svd.singularValues();
  const Eigen::MatrixXd v = svd.matrixV();
  post.cov = s2 * v * sv.array().square().inverse().matrix().asDiagonal() * v.transpose();
  return post;
}

// The prior-dominance report: each fitted parameter with its standard error and how much the
// runs narrowed its prior (noted where the prior dominates or the error is large), then the
// held ones.
void report_parameters(const std::vector<Slot>& slots, const Eigen::VectorXd& x,
                       const Eigen::MatrixXd& cov, const FitOptions& opt,
                       std::vector<FittedParameter> held, FitReport& rep) {
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    const Slot& s = slots[static_cast<std::size_t>(i)];
    FittedParameter p;
    p.name = s.name;
    p.value = std::exp(x[i]);
    p.log_std_error = std::sqrt(std::max(0.0, cov(i, i)));
    p.std_error = p.value * p.log_std_error;
    p.fitted = true;
    p.how = s.how;
    p.prior_median = s.prior.median;
    p.prior_log_sd = s.prior.log_sd;
    p.prior_source = s.prior.source;
    // How much the runs narrowed the prior: 1 - posterior / prior variance of the logarithm.
    p.data_share = std::clamp(1.0 - cov(i, i) / (s.prior.log_sd * s.prior.log_sd), 0.0, 1.0);
    p.prior_dominated = p.data_share < opt.min_data_share;
    if (p.prior_dominated)
      rep.notes.push_back(s.name + " is prior-dominated: " + fmt("%.4g", p.value) + " (x/ " +
                          fmt("%.2f", std::exp(p.log_std_error)) + " at one standard error); the " +
                          "runs narrowed its prior by " + fmt("%.0f %%", 100.0 * p.data_share) +
                          " of its variance (prior: " + s.prior.source + ")");
    else if (p.log_std_error > 0.3)
      rep.notes.push_back(s.name + " is poorly determined (relative standard error " +
                          fmt("%.0f %%", 100.0 * p.log_std_error) + ")");
    rep.parameters.push_back(p);
  }
  FittedParameter p;
  p.name = "l3.latency_ns";
  p.value = rep.platform.l3.latency_ns;
  p.how =
      "derived: = kernels.latency.ns_per_line_l3 (the pointer chase's load-to-use time within "
      "the L3); the model only uses latencies above it, so no time measurement identifies it";
  held.push_back(p);
  for (auto& h : held)
    rep.parameters.push_back(h);
}

// Each used run's residual and predicted time; a note for each run the model does not cover.
void report_runs(const Eigen::VectorXd& residuals, const std::vector<const KernelRun*>& used,
                 FitReport& rep) {
  for (std::size_t k = 0; FittedRun & fr : rep.runs) {
    if (!fr.used) {
      rep.notes.push_back("run " + std::to_string(fr.index) + " (" + fr.label + ") " + fr.note);
      continue;
    }
    fr.residual = residuals[static_cast<Eigen::Index>(k)] / weight_of(*used[k]);
    ++k;
    fr.predicted_ns = fr.measured_ns * std::exp(fr.residual);
  }
}

// The fit with the co-runners on the probed clusters (apart = false) or each core in a cluster of
// its own (apart = true).
FitReport fit_once(const Measurements& m, const FitOptions& opt, bool apart) {
  const HostFacts& host = m.host;
  if (host.freq_mhz <= 0 || host.l2_kb <= 0 || host.l3_kb_per_cluster <= host.l2_kb)
    throw RunError(
        "calibration: the host facts need freq_mhz, l2_kb and an l3_kb_per_cluster "
        "above l2_kb (got " +
        fmt("%g MHz, ", host.freq_mhz) + fmt("L2 %g KB, ", host.l2_kb) +
        fmt("L3 %g KB)", host.l3_kb_per_cluster));
  FitReport rep;
  SimPlatform base = model_platform(host);
  if (apart) {
    base.clusters *= base.cores_per_cluster;
    base.cores_per_cluster = 1;
  }
  const RunSelection sel = select_runs(m, base, rep);
  require_own_speeds(sel, host);
  note_unseen(sel, host, rep);
  const Priors priors = starting_point(sel, host, opt, base);
  Parameters params = free_parameters(sel, priors, opt, base, rep);
  hold_unidentified(opt, base, params);

  const auto n = static_cast<Eigen::Index>(params.free.size());
  Residuals fn{&base, &params.free, &sel.used};
  Eigen::VectorXd x(n);
  for (Eigen::Index i = 0; i < n; ++i)
    x[i] = std::log(params.free[static_cast<std::size_t>(i)].ref(base));
  const auto mres = static_cast<Eigen::Index>(sel.used.size());
  rep.dof = static_cast<int>(std::max<Eigen::Index>(1, mres - n));
  double s2 = solve_from_starts(fn, x, opt, rep.dof, rep);
  if (hold_beyond_range(base, params, x, rep)) {
    const int iterations = rep.iterations;
    rep.dof = static_cast<int>(std::max<Eigen::Index>(1, mres - x.size()));
    s2 = solve_from_starts(fn, x, opt, rep.dof, rep);
    rep.iterations += iterations;
  }
  const Posterior post = posterior(fn, x, s2, rep);
  if (rep.rms_residual > opt.max_rms_residual)
    throw RunError("calibration: the model cannot reproduce these measurements: RMS residual " +
                   fmt("%.3f", rep.rms_residual) + " (log units) above the limit " +
                   fmt("%.3f", opt.max_rms_residual) + lm_status_message(rep));

  rep.platform = fn.platform_at(x);
  rep.platform.l3.latency_ns = rep.platform.kernels.at("latency").ns_per_line_l3;
  report_parameters(params.free, x, post.cov, opt, std::move(params.held), rep);
  report_runs(post.residuals, sel.used, rep);
  for (const auto& [name, samples] : m.costs_us)
    if (!samples.empty())
      rep.costs[name] = name == "preemption" ? fit_mean_cost(samples) : fit_cost(samples);
  return rep;
}

// The runs' residual variance of a fit, for comparing two fits of the same runs: their weighted
// sum of squares over its degrees of freedom, at least the repeatability floor's square (as
// solve_map's sigma^2).
double residual_variance(const FitReport& r) {
  return std::max(r.data_ssr / r.dof, kCvFloor * kCvFloor);
}

}  // namespace

FitReport fit(const Measurements& m, const FitOptions& options) {
  // One core per probed cluster: both placements are the same model.
  const bool two = m.host.cores_per_cluster > 1 && options.placement == Placement::Best;
  const bool apart_only = m.host.cores_per_cluster > 1 && options.placement == Placement::Apart;
  // The two fits are independent: the apart one runs beside the probed one.
  std::future<FitReport> apart_fit;
  if (two || apart_only)
    apart_fit = std::async(std::launch::async, [&] { return fit_once(m, options, true); });
  std::optional<FitReport> probed, apart;
  std::optional<RunError> probed_error;
  if (!apart_only) {
    try {
      probed = fit_once(m, options, false);
    } catch (const RunError& e) {
      if (!two) throw;
      probed_error = e;
    }
  }
  if (apart_fit.valid()) {
    try {
      apart = apart_fit.get();
    } catch (const RunError&) {
      if (!two) throw;
      if (!probed) throw *probed_error;
    }
  }
  // Apart only where the runs favour it clearly: a likelihood ratio of e^2 (about 7) or more,
  // with the better fit's residual variance as the runs' noise (the probed clusters are what the
  // machine says, and two fits of similar quality do not contradict it).
  const bool chose_apart = apart && (!probed || probed->data_ssr - apart->data_ssr >
                                                    4.0 * std::min(residual_variance(*probed),
                                                                   residual_variance(*apart)));
  FitReport rep = chose_apart ? std::move(*apart) : std::move(*probed);
  rep.placement = chose_apart ? "apart" : "probed";
  rep.rms_probed = probed ? probed->rms_residual : std::nan("");
  rep.rms_apart = apart ? apart->rms_residual : std::nan("");
  const std::string cluster = std::to_string(m.host.cores_per_cluster) + " cores sharing an L3";
  if (two) {
    const auto rms = [](const std::optional<FitReport>& r) {
      return r ? fmt("RMS residual %.1f %%", 100.0 * r->rms_residual) : std::string("refused");
    };
    const std::string why =
        chose_apart ? "each in a cluster of its own (its own L3), which the runs favour"
        : apart && apart->data_ssr < probed->data_ssr
            ? "in the probed clusters (" + cluster +
                  "), kept: the runs do not favour each core its own L3 by a likelihood ratio "
                  "of e^2"
            : "in the probed clusters (" + cluster + "), the better fit";
    rep.notes.insert(rep.notes.begin(),
                     "placement: the co-runners " + why + ": " + rms(probed) +
                         " with the probed clusters, " + rms(apart) +
                         " with each core its own L3 (the L3 a virtual machine reports as "
                         "shared is shared only while the host runs its vCPUs on one)");
  } else if (apart_only) {
    rep.notes.insert(rep.notes.begin(),
                     "placement: each core in a cluster of its own (its own L3), as asked; the "
                     "probe saw " +
                         cluster);
  }
  if (options.strict) {
    // A bound first: there the model cannot follow the runs, whatever the priors.
    for (const auto& p : rep.parameters)
      if (p.at_bound)
        throw RunError("calibration: " + p.name + " " + p.how +
                       "; leave --strict off to keep the model with it there");
    for (const auto& p : rep.parameters)
      if (p.prior_dominated)
        throw UnidentifiedParameter(
            "calibration: the data cannot identify " + p.name + " (fitted " + fmt("%.4g", p.value) +
                ", standard error of its logarithm " + fmt("%.3g", p.log_std_error) +
                ": the runs narrowed its prior by only " + fmt("%.0f %%", 100.0 * p.data_share) +
                "); measure what identifies it (" + p.how +
                ") or leave --strict off to keep the prior-dominated value",
            p.name, p.value, p.log_std_error);
  }
  return rep;
}

namespace {

// "<key> <how it was found>" of each named parameter of rep, "; "-separated: for a platform
// file's "source".
std::string describe(const FitReport& rep, std::initializer_list<const char*> names) {
  const auto param = [&](const std::string& n) -> const FittedParameter& {
    for (const auto& q : rep.parameters)
      if (q.name == n) return q;
    throw RunError("calibration report has no parameter " + n);
  };
  std::string s;
  for (const char* n : names) {
    const FittedParameter& q = param(n);
    const std::string key = std::string(n).substr(std::string(n).rfind('.') + 1);
    s += (s.empty() ? "" : "; ") + key + " " +
         (!q.fitted ? q.how
          : q.prior_dominated
              ? "PRIOR-DOMINATED +- " + fmt("%.2g", q.std_error) +
                    " (the runs narrowed its "
                    "prior by " +
                    fmt("%.0f %%", 100.0 * q.data_share) + "; prior: " + q.prior_source + ")"
              : "fitted +- " + fmt("%.2g", q.std_error) + " (" + q.how + ")");
  }
  return s;
}

// The platform's name, description, cpu, caches and pmu: the host facts, as `by` saw them.
void host_sections(const HostFacts& h, const SimPlatform& p, const std::string& by, json& doc) {
  doc["description"] = "This host as measured by rosguard calibrate" +
                       (h.hostname.empty() ? std::string() : " on " + h.hostname) + " at " +
                       h.date + " (" + std::to_string(h.cpus) + " CPUs" +
                       (h.cpu_model.empty() ? std::string() : ", " + h.cpu_model) +
                       "): memory model and kernel models fitted to its measurements, costs from "
                       "its samples.";
  const std::string clusters = p.cores_per_cluster == h.cores_per_cluster
                                   ? ""
                                   : "; clusters of one core, not the probed " +
                                         std::to_string(h.cores_per_cluster) +
                                         " cores sharing an L3 (the fit's placement note says why)";
  json cpu = {{"clusters", p.clusters},
              {"cores_per_cluster", p.cores_per_cluster},
              {"freq_mhz", p.freq_mhz},
              {"source", "host facts seen by " + by + " (rosguard platform probe)" + clusters}};
  if (!h.cpu_model.empty()) cpu["model"] = h.cpu_model;
  doc["cpu"] = cpu;
  json caches = {{"line_bytes", h.line_bytes},
                 {"l2_kb", h.l2_kb},
                 {"l3_kb_per_cluster", h.l3_kb_per_cluster},
                 {"source", "host facts seen by " + by + " (rosguard platform probe)"}};
  if (h.l1d_kb > 0) caches["l1d_kb"] = h.l1d_kb;
  doc["caches"] = caches;
  doc["pmu"] = {{"events", {"l2d_cache_refill", "l2d_cache_wb"}},
                {"counter_bits", 64},
                {"source",
                 "the events the sim's cores count for the built-in kernels' traffic "
                 "(and the hw backend's instrumented source provides); not probed "
                 "by rosguard calibrate"}};
}

// Reference: Eq. 1 (MiB/s) of bandwidth_read over 2048 KB alone, measured if the suite ran it,
// else as the fitted model predicts it.
json reference_section(const Measurements& m, const SimPlatform& p, const std::string& by) {
  const KernelRun* ref = nullptr;
  for (const auto& r : m.runs)
    if (r.kernel == "bandwidth_read" && r.working_set_kb == 2048.0 && r.corunners.empty()) ref = &r;
  if (ref)
    return {{"mbps", round_sig(mbps_of(1.0 / ref->ns_per_line), 6)},
            {"source",
             "bandwidth_read (2048 KB working set, one load per 64-byte line) alone, "
             "measured by " +
                 by + ": median of " + std::to_string(ref->samples) + " runs, cv " +
                 fmt("%.1f %%", 100.0 * ref->cv)}};
  const double ns = predict_ns_per_line(p, {"bandwidth_read", 2048.0, {}, 0.0, 0.0, 0});
  return {{"mbps", round_sig(mbps_of(1.0 / ns), 6)},
          {"source", "bandwidth_read (2048 KB) alone as predicted by the model fitted by " + by +
                         " (the suite did not measure 2048 KB)"}};
}

double sig(double v) {
  return round_sig(v, 5);
}

// The fitted memory model and kernel models, each with how its parameters were found.
void model_sections(const FitReport& rep, const std::string& by, json& doc) {
  const SimPlatform& p = rep.platform;
  std::size_t used = 0;
  for (const auto& r : rep.runs)
    used += r.used ? 1 : 0;
  const std::string residual = "RMS residual " + fmt("%.1f %%", 100.0 * rep.rms_residual) +
                               " (log ratio predicted / measured ns per line) over " +
                               std::to_string(used) + " runs";
  doc["memory"] = {
      {"l3",
       {{"latency_ns", sig(p.l3.latency_ns)},
        {"queue_ns", sig(p.l3.queue_ns)},
        {"bandwidth_mbps", sig(p.l3.bandwidth_mbps)},
        {"source", "fitted by " + by + ", " + residual + ": " +
                       describe(rep, {"l3.latency_ns", "l3.queue_ns", "l3.bandwidth_mbps"})}}},
      {"dram",
       {{"latency_ns", sig(p.dram.latency_ns)},
        {"queue_ns", sig(p.dram.queue_ns)},
        {"bandwidth_mbps", sig(p.dram.bandwidth_mbps)},
        {"writeback_weight", sig(p.dram.writeback_weight)},
        {"source", "fitted by " + by + ", " + residual + ": " +
                       describe(rep, {"dram.latency_ns", "dram.queue_ns", "dram.bandwidth_mbps",
                                      "dram.writeback_weight"})}}},
      {"mshr",
       {{"per_core", sig(p.mshr.per_core)},
        {"per_cluster", sig(p.mshr.per_cluster)},
        {"source",
         "not fitted by " + by + ": " + describe(rep, {"mshr.per_core", "mshr.per_cluster"})}}},
      {"core",
       {{"callback_ipc", 0.8},
        {"idle_loop_ipc", 1.0},
        {"source",
         "not measured by rosguard calibrate: estimates as for orin-agx (they only "
         "affect the inst_retired and IPC of nRT cores)"}}},
      {"source",
       "model: sim/platform/contention.h, fitted with sim/calibration/fit.h (Eigen "
       "Levenberg-Marquardt, " +
           rep.lm_status_text + ")"}};

  json kernels = {{"source", "fitted by " + by + ", " + residual +
                                 "; model: sim/workload/profile.h (kernel_profile)"}};
  for (const auto& [k, km] : p.kernels)
    kernels[k] = {{"ns_per_line_l2", sig(km.ns_per_line_l2)},
                  {"ns_per_line_l3", sig(km.ns_per_line_l3)},
                  {"mlp", sig(km.mlp)},
                  {"source", "fitted by " + by + ": " +
                                 describe(rep, {("kernels." + k + ".ns_per_line_l2").c_str(),
                                                ("kernels." + k + ".ns_per_line_l3").c_str(),
                                                ("kernels." + k + ".mlp").c_str()})}};
  doc["kernels"] = kernels;
}

// The fit's quality: its RMS residual and the parameters that rest on their priors.
json fit_section(const FitReport& rep, const std::string& by) {
  json dominated = json::array();
  for (const auto& q : rep.parameters)
    if (q.prior_dominated)
      dominated.push_back({{"parameter", q.name},
                           {"value", sig(q.value)},
                           {"log_std_error", round_sig(q.log_std_error, 3)},
                           {"data_share", round_sig(q.data_share, 3)},
                           {"prior_source", q.prior_source}});
  return {{"rms_residual", round_sig(rep.rms_residual, 4)},
          {"prior_dominated", dominated},
          {"source", "the fit of " + by + " (calibration.json has every parameter)"}};
}

// The cost distributions fitted to the samples; throws when a required cost has none.
json cost_section(const FitReport& rep, const std::string& by) {
  json costs = json::object();
  std::vector<std::string> missing;
  // The local variants are optional (older measurements, a suite on one core); the others are
  // the platform's required costs.
  const auto optional = [](const std::string& c) {
    return c == "local_message_latency" || c == "controller_callback_local" ||
           c == "timer_wakeup" || c == "preemption";
  };
  for (const char* c : {"pmc_callback", "publish", "message_latency", "local_message_latency",
                        "controller_callback", "controller_callback_local", "throttle_activation",
                        "external_read", "timer_wakeup", "preemption"}) {
    const auto it = rep.costs.find(c);
    if (it == rep.costs.end()) {
      if (!optional(c)) missing.push_back(c);
      continue;
    }
    const CostFit& cf = it->second;
    json d = cf.distribution;
    if (std::string(c) == "preemption")
      d["source"] = "measured by " + by + ": the median of " + std::to_string(cf.samples) +
                    " pairs of timed windows (a memory stream alone and beside an empty thread "
                    "woken by its timer on its core: the extra time per wake-up, less "
                    "timer_wakeup_us's median): " +
                    fmt("%.3g", cf.median_us) + " us" +
                    (cf.median_us < 0.0 ? ", held at 0 (no cost, not a negative one)" : "") +
                    "; min " + fmt("%.3g", cf.min_us) + ", max " + fmt("%.3g", cf.max_us) + " us";
    else
      d["source"] = "fitted by " + by + " to " + std::to_string(cf.samples) + " samples: min " +
                    fmt("%.3g", cf.min_us) + ", median " + fmt("%.3g", cf.median_us) + ", p90 " +
                    fmt("%.3g", cf.p90_us) + ", max " + fmt("%.3g", cf.max_us) + " us";
    costs[std::string(c) + "_us"] = d;
  }
  if (!missing.empty()) {
    std::string msg = "calibration: no cost samples for";
    for (const auto& c : missing)
      msg += " " + c;
    throw RunError(msg + "; the platform's \"costs\" needs every one of them");
  }
  return costs;
}

}  // namespace

json fitted_platform(const Measurements& m, const FitReport& rep, std::string name) {
  const HostFacts& h = m.host;
  const std::string by =
      "rosguard calibrate on " + (h.hostname.empty() ? "this host" : h.hostname) + " at " + h.date;
  json doc;
  doc["name"] = std::move(name);
  host_sections(h, rep.platform, by, doc);
  doc["reference"] = reference_section(m, rep.platform, by);
  model_sections(rep, by, doc);
  doc["fit"] = fit_section(rep, by);
  doc["costs"] = cost_section(rep, by);
  return doc;
}

std::vector<std::pair<std::string, json>> band_platforms(const json& platform,
                                                         const FitReport& rep) {
  std::vector<std::pair<std::string, json>> out;
  const std::string name = platform.value("name", std::string("host"));
  for (const auto& q : rep.parameters) {
    if (!q.prior_dominated) continue;
    // "kernels.<kernel>.<key>" or "<l3|dram>.<key>" (memory).
    const auto dot = q.name.rfind('.');
    const std::string key = q.name.substr(dot + 1);
    const std::string owner = q.name.substr(0, dot);
    const json::json_pointer section(
        owner.starts_with("kernels.") ? "/kernels/" + owner.substr(std::string("kernels.").size())
                                      : "/memory/" + owner);
    const double factor = std::exp(q.log_std_error);
    for (const auto& [side, value] : {std::pair{std::string("low"), q.value / factor},
                                      std::pair{std::string("high"), q.value * factor}}) {
      json doc = platform;
      doc[section][key] = round_sig(value, 5);
      doc[section]["source"] = doc[section].value("source", std::string()) + "; " + q.name +
                               " moved one standard error " + (side == "low" ? "down" : "up") +
                               " (x/ " + fmt("%.3g", factor) + ") for the uncertainty band";
      const std::string variant = name + "-" + q.name + "-" + side;
      doc["name"] = variant;
      doc["description"] = "Uncertainty band of " + name + ": " + q.name +
                           " (prior-dominated) at " + fmt("%.4g", value) +
                           ", one posterior standard error " + (side == "low" ? "below" : "above") +
                           " the fitted " + fmt("%.4g", q.value) + "; everything else as fitted.";
      out.emplace_back(variant, std::move(doc));
    }
  }
  return out;
}

json to_json(const FitReport& rep) {
  json j;
  j["converged"] = rep.converged;
  j["lm_status"] = rep.lm_status;
  j["lm_status_text"] = rep.lm_status_text;
  j["evaluations"] = rep.evaluations;
  j["iterations"] = rep.iterations;
  j["rms_residual"] = rep.rms_residual;
  // NaN (not tried, or refused) is written as null.
  j["placement"] = {
      {"chosen", rep.placement}, {"rms_probed", rep.rms_probed}, {"rms_apart", rep.rms_apart}};
  j["parameters"] = json::array();
  for (const auto& p : rep.parameters) {
    json o = {{"name", p.name},
              {"value", p.value},
              {"std_error", p.std_error},
              {"fitted", p.fitted},
              {"how", p.how}};
    if (p.fitted) {
      o["log_std_error"] = p.log_std_error;
      o["prior"] = {
          {"median", p.prior_median}, {"log_sd", p.prior_log_sd}, {"source", p.prior_source}};
      o["data_share"] = p.data_share;
      o["prior_dominated"] = p.prior_dominated;
    }
    if (p.at_bound) o["at_bound"] = true;
    j["parameters"].push_back(o);
  }
  j["runs"] = json::array();
  for (const auto& r : rep.runs) {
    json o = {
        {"index", r.index}, {"label", r.label}, {"measured_ns", r.measured_ns}, {"used", r.used}};
    if (r.used) {
      o["predicted_ns"] = r.predicted_ns;
      o["residual"] = r.residual;
    } else {
      o["note"] = r.note;
    }
    j["runs"].push_back(o);
  }
  j["costs"] = json::object();
  for (const auto& [name, c] : rep.costs)
    j["costs"][name] = {
        {"distribution", c.distribution}, {"samples", c.samples}, {"min_us", c.min_us},
        {"median_us", c.median_us},       {"p90_us", c.p90_us},   {"max_us", c.max_us}};
  j["notes"] = rep.notes;
  return j;
}

}  // namespace rosguard::calibration

#include "calibration/fit.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <numeric>
#include <set>
#include <unsupported/Eigen/NonLinearOptimization>

#include "core/error.h"
#include "platform/contention.h"
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

// One free parameter: where it lives in the platform, and what identifies it.
struct Slot {
  std::string name;
  std::function<double&(SimPlatform&)> ref;
  std::string how;
};

// A run's weight in the fit: kCvFloor / max(cv, kCvFloor). Runs whose repetitions scatter
// (another tenant's traffic, a cache shared with the host) count less, in proportion to their
// coefficient of variation; below the floor (the repeatability of a 20 ms window here, about
// 2 %) every run counts the same.
constexpr double kCvFloor = 0.02;
double weight_of(const KernelRun& run) {
  return kCvFloor / std::max(std::isfinite(run.cv) ? run.cv : 1.0, kCvFloor);
}

// The weighted residuals weight * log(predicted / measured) of the used runs as a function of the
// log parameters, for Eigen's LM (minpack interface: operator() and df()).
struct Residuals {
  using Scalar = double;
  enum { InputsAtCompileTime = Eigen::Dynamic, ValuesAtCompileTime = Eigen::Dynamic };
  using InputType = Eigen::VectorXd;
  using ValueType = Eigen::VectorXd;
  using JacobianType = Eigen::MatrixXd;

  const SimPlatform* base;
  const std::vector<Slot>* slots;
  const std::vector<std::function<void(SimPlatform&)>>* ties;  // after the slots, in order
  const std::vector<const KernelRun*>* runs;
  mutable int evaluations = 0;

  int inputs() const { return static_cast<int>(slots->size()); }
  int values() const { return static_cast<int>(runs->size()); }

  SimPlatform platform_at(const Eigen::VectorXd& x) const {
    SimPlatform p = *base;
    for (std::size_t i = 0; i < slots->size(); ++i)
      (*slots)[i].ref(p) = std::exp(x[static_cast<Eigen::Index>(i)]);
    for (const auto& tie : *ties)
      tie(p);
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
    return 0;
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

double quantile(const std::vector<double>& sorted, double q) {
  const double pos = q * static_cast<double>(sorted.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, sorted.size() - 1);
  return sorted[lo] + (pos - static_cast<double>(lo)) * (sorted[hi] - sorted[lo]);
}

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
  if (static_cast<int>(run.corunners.size()) >= platform.cores_per_cluster)
    throw RunError("calibration run '" + label_of(run) + "' has " +
                   std::to_string(run.corunners.size()) + " co-runners, but a cluster of " +
                   platform.name + " has only " + std::to_string(platform.cores_per_cluster) +
                   " cores");
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
  std::vector<sim::CoreDemand> demands;
  for (const auto& w : profiles)
    demands.push_back({0, &w.phases[0], &w, true, &w.phases[0]});
  const sim::ContentionModel model(platform);
  const sim::MemoryState st = model.solve(demands);
  const sim::CoreRates r = model.rates(profiles[0].phases[0], st.l3_hit[0], 0, st);
  return 1.0 / r.inst_per_ns;  // one instruction per line
}

CostFit fit_cost(std::vector<double> samples) {
  if (samples.empty()) throw RunError("a cost distribution needs samples");
  std::sort(samples.begin(), samples.end());
  CostFit c;
  c.samples = samples.size();
  c.min_us = samples.front();
  c.max_us = samples.back();
  c.median_us = quantile(samples, 0.5);
  c.p90_us = quantile(samples, 0.9);
  if (c.max_us <= c.min_us) {
    c.distribution = {{"dist", "constant"}, {"value_us", round_sig(c.min_us, 4)}};
    return c;
  }
  // A shifted lognormal loc + m exp(sigma N(0,1)) through the 10th, 50th and 90th percentiles:
  // (q90 - loc)(q10 - loc) = (q50 - loc)^2 gives the location, which must lie in [0, min].
  constexpr double kZ90 = 1.2815515655446004;  // standard normal 90th percentile
  const double q10 = quantile(samples, 0.1);
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
  // Not right-skewed: a normal by mean and sd, truncated to the samples' range.
  const double mean =
      std::accumulate(samples.begin(), samples.end(), 0.0) / static_cast<double>(samples.size());
  double var = 0.0;
  for (double x : samples)
    var += (x - mean) * (x - mean);
  const double sd =
      std::sqrt(var / static_cast<double>(std::max<std::size_t>(1, samples.size() - 1)));
  c.distribution = {{"dist", "normal"},
                    {"mean_us", round_sig(mean, 4)},
                    {"sd_us", round_sig(sd, 3)},
                    {"min_us", c.min_us},
                    {"max_us", c.max_us}};
  return c;
}

namespace {

FitReport fit_once(const Measurements& m, const FitOptions& opt) {
  const HostFacts& host = m.host;
  if (host.freq_mhz <= 0 || host.l2_kb <= 0 || host.l3_kb_per_cluster <= host.l2_kb)
    throw RunError(
        "calibration: the host facts need freq_mhz, l2_kb and an l3_kb_per_cluster "
        "above l2_kb (got " +
        fmt("%g MHz, ", host.freq_mhz) + fmt("L2 %g KB, ", host.l2_kb) +
        fmt("L3 %g KB)", host.l3_kb_per_cluster));
  FitReport rep;
  SimPlatform base = model_platform(host);

  // Which runs the model covers, and what they can identify.
  std::vector<const KernelRun*> used;
  std::map<std::string, std::map<Level, std::vector<double>>> iso;  // kernel -> level -> ns
  bool l3_corun = false, dram_corun = false;
  // Co-runner counts of the bandwidth-latency curves: within the L3 (co-runners beyond the L2)
  // and beyond it (co-runners beyond the L3).
  std::set<std::size_t> l3_counts, dram_counts;
  std::map<std::string, bool> beyond_l3;  // kernel measured beyond the L3 (iso or co-run)
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
    } else if (static_cast<int>(r.corunners.size()) >= base.cores_per_cluster) {
      fr.note = "not modelled: more co-runners than the cluster has other cores";
    } else if (lv == Level::L1) {
      fr.note = "not modelled: the working set fits the L1d (the model starts at the L2)";
    } else {
      fr.used = true;
      used.push_back(&r);
      if (r.corunners.empty()) iso[r.kernel][lv].push_back(r.ns_per_line);
      if (lv == Level::Dram) beyond_l3[r.kernel] = true;
      std::size_t co_l3 = 0, co_dram = 0;
      for (const auto& c : r.corunners) {
        co_l3 += c.working_set_kb > host.l2_kb ? 1 : 0;
        co_dram += c.working_set_kb > host.l3_kb_per_cluster ? 1 : 0;
      }
      if (lv == Level::L3 && co_l3 > 0) l3_counts.insert(co_l3);
      if (lv == Level::Dram && co_dram > 0) dram_counts.insert(co_dram);
      l3_corun = l3_corun || (lv == Level::L3 && co_l3 > 0);
      dram_corun = dram_corun || (lv == Level::Dram && co_dram > 0);
    }
    rep.runs.push_back(fr);
  }

  // What the data must contain; every gap is named.
  std::vector<std::string> missing;
  const auto l2s = fmt("%g KB", host.l2_kb), l3s = fmt("%g KB", host.l3_kb_per_cluster);
  for (const char* need : {"bandwidth_read", "latency"})
    if (!iso.count(need)) missing.push_back(std::string("isolation runs of ") + need);
  for (const auto& [k, levels] : iso) {
    if (!levels.count(Level::L2))
      missing.push_back("an isolation run of " + k + " within the L2 (<= " + l2s + ")");
    if (!levels.count(Level::L3))
      missing.push_back("an isolation run of " + k + " within the L3 (" + l2s + " .. " + l3s + ")");
    if (!beyond_l3.count(k)) missing.push_back("a run of " + k + " beyond the L3 (> " + l3s + ")");
  }
  if (iso.count("latency") && !iso.at("latency").count(Level::Dram))
    missing.push_back("an isolation run of latency beyond the L3 (the DRAM latency)");
  if (!l3_corun && !(opt.fixed.count("l3.queue_ns") && opt.fixed.count("l3.bandwidth_mbps")))
    missing.push_back(
        "a co-run within the L3 (a kernel within the L3 with a co-runner beyond "
        "the L2): the L3 queue and bandwidth");
  if (!dram_corun && !(opt.fixed.count("dram.queue_ns") && opt.fixed.count("dram.bandwidth_mbps")))
    missing.push_back(
        "a co-run beyond the L3 (a kernel and a co-runner beyond the L3): the DRAM "
        "queue and bandwidth");
  if (!missing.empty()) {
    std::string msg = "calibration: insufficient measurements to fit the memory model; missing: ";
    for (std::size_t i = 0; i < missing.size(); ++i)
      msg += (i ? "; " : "") + missing[i];
    throw RunError(msg);
  }

  // Starting point from the data directly, and the free parameters.
  for (const auto& [k, levels] : iso) {
    sim::KernelModel km;
    km.ns_per_line_l2 = geomean(levels.at(Level::L2));
    km.ns_per_line_l3 = geomean(levels.at(Level::L3));
    base.kernels[k] = km;
  }
  const double lat_l3 = base.kernels.at("latency").ns_per_line_l3;
  const double lat_dram = geomean(iso.at("latency").at(Level::Dram));
  base.l3.latency_ns = lat_l3;
  base.dram.latency_ns = std::max(lat_dram - lat_l3, 0.5 * lat_dram);
  for (auto& [k, km] : base.kernels) {
    km.mlp = 1.0;
    if (k == "latency") continue;
    const auto d = iso.at(k).find(Level::Dram);
    const double extra = d == iso.at(k).end() ? 0.0 : geomean(d->second) - km.ns_per_line_l3;
    km.mlp = extra > 0 ? std::clamp(base.dram.latency_ns / extra, 1.0, 64.0) : 8.0;
  }
  // Bandwidths: 1.5x the largest traffic a run shows at each level (every core beyond the L2 at
  // the measured kernel's rate); queues: the unloaded latencies.
  double l3_peak = 0.0, dram_peak = 0.0;
  for (const KernelRun* r : used) {
    const double rate = lines_moved(r->kernel) / r->ns_per_line;
    double l3_cores = r->working_set_kb > host.l2_kb ? 1.0 : 0.0;
    double dram_cores = r->working_set_kb > host.l3_kb_per_cluster ? 1.0 : 0.0;
    for (const auto& c : r->corunners) {
      l3_cores += c.working_set_kb > host.l2_kb ? 1.0 : 0.0;
      dram_cores += c.working_set_kb > host.l3_kb_per_cluster ? 1.0 : 0.0;
    }
    l3_peak = std::max(l3_peak, mbps_of(rate * l3_cores));
    dram_peak = std::max(dram_peak, mbps_of(rate * dram_cores));
  }
  base.l3.bandwidth_mbps = 1.5 * l3_peak;
  base.l3.queue_ns = lat_l3;
  base.dram.bandwidth_mbps = 1.5 * dram_peak;
  base.dram.queue_ns = base.dram.latency_ns;
  base.mshr.per_core = opt.mshr_per_core;
  base.mshr.per_cluster = opt.mshr_per_cluster;

  std::vector<Slot> slots;
  std::vector<FittedParameter> fixed_params;
  const auto add = [&](const std::string& name, std::function<double&(SimPlatform&)> ref,
                       const std::string& how) {
    if (const auto it = opt.fixed.find(name); it != opt.fixed.end()) {
      if (!(it->second > 0))
        throw RunError("calibration: fixed value of " + name + " must be positive");
      ref(base) = it->second;
      fixed_params.push_back({name, it->second, 0.0, false, "fixed by the caller"});
      rep.notes.push_back(name + " fixed by the caller at " + fmt("%g", it->second));
      return;
    }
    slots.push_back({name, std::move(ref), how});
  };
  for (const auto& [k, km] : base.kernels) {
    const std::string kk = k;
    add(
        "kernels." + k + ".ns_per_line_l2",
        [kk](SimPlatform& p) -> double& { return p.kernels.at(kk).ns_per_line_l2; },
        "isolation runs of " + k + " within the L2");
    add(
        "kernels." + k + ".ns_per_line_l3",
        [kk](SimPlatform& p) -> double& { return p.kernels.at(kk).ns_per_line_l3; },
        "isolation runs of " + k + " within the L3");
    if (k != "latency")
      add(
          "kernels." + k + ".mlp", [kk](SimPlatform& p) -> double& { return p.kernels.at(kk).mlp; },
          "runs of " + k + " beyond the L3, given the DRAM latency");
  }
  // One loaded level per resource (a 2-core cluster: 0 or 1 co-runner) shows how much the
  // latency grows, not how it bends: the queue and the bandwidth then trade off against each
  // other, so the queue is tied to the unloaded latency (the delay doubles at half load) and the
  // bandwidth is fitted. Two or more co-runner counts identify both.
  std::vector<std::function<void(SimPlatform&)>> ties;
  const auto tie = [&](const std::string& name, std::function<void(SimPlatform&)> f,
                       const std::string& how) {
    ties.push_back(std::move(f));
    rep.notes.push_back(name + " " + how);
    fixed_params.push_back({name, 0.0, 0.0, false, how});
  };
  if (l3_counts.size() >= 2 || opt.fixed.count("l3.queue_ns"))
    add(
        "l3.queue_ns", [](SimPlatform& p) -> double& { return p.l3.queue_ns; },
        "co-runs within the L3 at " + std::to_string(l3_counts.size()) + " co-runner counts");
  else
    tie(
        "l3.queue_ns",
        [](SimPlatform& p) { p.l3.queue_ns = p.kernels.at("latency").ns_per_line_l3; },
        "tied to l3.latency_ns: the co-runs within the L3 have one co-runner count, which "
        "cannot separate the queue from the bandwidth");
  add(
      "l3.bandwidth_mbps", [](SimPlatform& p) -> double& { return p.l3.bandwidth_mbps; },
      "co-runs within the L3");
  add(
      "dram.latency_ns", [](SimPlatform& p) -> double& { return p.dram.latency_ns; },
      "the latency kernel (one load in flight) beyond the L3");
  if (dram_counts.size() >= 2 || opt.fixed.count("dram.queue_ns"))
    add(
        "dram.queue_ns", [](SimPlatform& p) -> double& { return p.dram.queue_ns; },
        "co-runs beyond the L3 at " + std::to_string(dram_counts.size()) + " co-runner counts");
  else
    tie(
        "dram.queue_ns", [](SimPlatform& p) { p.dram.queue_ns = p.dram.latency_ns; },
        "tied to dram.latency_ns: the co-runs beyond the L3 have one co-runner count, which "
        "cannot separate the queue from the bandwidth");
  add(
      "dram.bandwidth_mbps", [](SimPlatform& p) -> double& { return p.dram.bandwidth_mbps; },
      "co-runs beyond the L3");
  // The misses-in-flight bounds: the suite's runs cannot tell a kernel's mlp from the core's
  // buffers (nor, with at most one co-runner count, the cluster's), so both are held where they
  // do not bind unless the caller fixes them. The runs that overflow the L3 together are
  // predicted by the shared-LRU model, which has no parameter.
  for (const auto& [name, value, ref] :
       {std::tuple{std::string("mshr.per_core"), base.mshr.per_core,
                   std::function<double&(SimPlatform&)>(
                       [](SimPlatform& p) -> double& { return p.mshr.per_core; })},
        std::tuple{std::string("mshr.per_cluster"), base.mshr.per_cluster,
                   std::function<double&(SimPlatform&)>(
                       [](SimPlatform& p) -> double& { return p.mshr.per_cluster; })}}) {
    if (const auto it = opt.fixed.find(name); it != opt.fixed.end()) {
      ref(base) = it->second;
      fixed_params.push_back({name, it->second, 0.0, false, "fixed by the caller"});
      continue;
    }
    fixed_params.push_back({name, value, 0.0, false,
                            "held at " + fmt("%g", value) +
                                " (not identified: the runs cannot tell a kernel's misses in "
                                "flight from the buffers' bound; this value does not bind)"});
  }
  fixed_params.push_back(
      {"kernels.latency.mlp", 1.0, 0.0, false, "fixed: a pointer chase has one load in flight"});

  const auto n = static_cast<Eigen::Index>(slots.size());
  const auto mres = static_cast<Eigen::Index>(used.size());
  if (mres <= n)
    throw RunError("calibration: " + std::to_string(mres) + " usable runs for " +
                   std::to_string(n) +
                   " free parameters; the fit needs more runs than parameters (to estimate the "
                   "residual variance)");

  Residuals fn{&base, &slots, &ties, &used};
  Eigen::VectorXd x(n);
  for (Eigen::Index i = 0; i < n; ++i)
    x[i] = std::log(slots[static_cast<std::size_t>(i)].ref(base));
  Eigen::LevenbergMarquardt<Residuals> lm(fn);
  lm.parameters.maxfev = opt.max_evaluations;
  lm.parameters.ftol = 1e-12;
  lm.parameters.xtol = 1e-10;
  const auto status = lm.minimize(x);
  rep.lm_status = static_cast<int>(status);
  rep.lm_status_text = status_text(rep.lm_status);
  rep.evaluations = fn.evaluations;
  rep.iterations = static_cast<int>(lm.iter);
  rep.converged = converged_status(rep.lm_status);
  const std::string status_msg = " (Levenberg-Marquardt status " + std::to_string(rep.lm_status) +
                                 ": " + rep.lm_status_text + ", " +
                                 std::to_string(rep.evaluations) + " evaluations)";
  if (!rep.converged) throw RunError("calibration: the fit did not converge" + status_msg);

  // Residuals, residual variance, Jacobian at the solution.
  Eigen::VectorXd f(mres);
  fn(x, f);
  Eigen::MatrixXd jac(mres, n);
  fn.df(x, jac);
  const double ssr = f.squaredNorm();
  double sum_w2 = 0.0;
  for (const KernelRun* r : used)
    sum_w2 += weight_of(*r) * weight_of(*r);
  rep.rms_residual = std::sqrt(ssr / sum_w2);  // weighted RMS of the log ratios
  rep.objective = ssr;
  rep.dof = static_cast<int>(mres - n);
  const double s2 = ssr / static_cast<double>(mres - n);

  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(jac, Eigen::ComputeThinV);
  const Eigen::VectorXd sv = svd.singularValues();
  constexpr double kRankTol = 1e-7;  // of the largest singular value
  if (sv.size() > 0 && (sv[sv.size() - 1] <= kRankTol * sv[0])) {
    Eigen::Index worst = 0;
    svd.matrixV().col(sv.size() - 1).cwiseAbs().maxCoeff(&worst);
    const Slot& s = slots[static_cast<std::size_t>(worst)];
    throw UnidentifiedParameter(
        "calibration: the data cannot identify " + s.name +
            " (the Jacobian is rank-deficient: singular values " + fmt("%.3g", sv[0]) + " .. " +
            fmt("%.3g", sv[sv.size() - 1]) + "); measure what identifies it (" + s.how +
            ") or fix it" + status_msg,
        s.name, std::exp(x[worst]), std::numeric_limits<double>::infinity());
  }
  // (J^T J)^-1 from the SVD: V diag(1/s^2) V^T.
  const Eigen::MatrixXd v = svd.matrixV();
  const Eigen::MatrixXd cov =
      s2 * v * sv.array().square().inverse().matrix().asDiagonal() * v.transpose();

  if (rep.rms_residual > opt.max_rms_residual)
    throw RunError("calibration: the model cannot reproduce these measurements: RMS residual " +
                   fmt("%.3f", rep.rms_residual) + " (log units) above the limit " +
                   fmt("%.3f", opt.max_rms_residual) + status_msg);

  rep.platform = fn.platform_at(x);
  rep.platform.l3.latency_ns = rep.platform.kernels.at("latency").ns_per_line_l3;
  for (Eigen::Index i = 0; i < n; ++i) {
    const Slot& s = slots[static_cast<std::size_t>(i)];
    const double value = std::exp(x[i]);
    const double se_log = std::sqrt(std::max(0.0, cov(i, i)));
    // Numerically full rank, statistically not identified: the data leave the parameter free
    // over more than a factor exp(max_log_std_error) (e.g. a queue driven towards 0).
    if (!(se_log <= opt.max_log_std_error))
      throw UnidentifiedParameter(
          "calibration: the data cannot identify " + s.name + " (fitted " + fmt("%.4g", value) +
              ", standard error of its logarithm " + fmt("%.3g", se_log) + " above " +
              fmt("%.3g", opt.max_log_std_error) + "); measure what identifies it (" + s.how +
              ") or fix it" + status_msg,
          s.name, value, se_log);
    rep.parameters.push_back({s.name, value, value * se_log, true, s.how});
    if (se_log > 0.3)
      rep.notes.push_back(s.name + " is poorly determined (relative standard error " +
                          fmt("%.0f %%", 100.0 * se_log) + ")");
  }
  fixed_params.push_back({"l3.latency_ns", rep.platform.l3.latency_ns, 0.0, false,
                          "derived: = kernels.latency.ns_per_line_l3 (the pointer chase's "
                          "load-to-use time within the L3); the model only uses latencies above "
                          "it, so no time measurement identifies it"});
  for (auto& p : fixed_params) {
    // Tied and derived values: as the fitted platform holds them.
    if (p.name == "l3.queue_ns") p.value = rep.platform.l3.queue_ns;
    if (p.name == "dram.queue_ns") p.value = rep.platform.dram.queue_ns;
    rep.parameters.push_back(p);
  }

  std::size_t k = 0;
  for (FittedRun& fr : rep.runs) {
    if (!fr.used) {
      rep.notes.push_back("run " + std::to_string(fr.index) + " (" + fr.label + ") " + fr.note);
      continue;
    }
    fr.residual = f[static_cast<Eigen::Index>(k)] / weight_of(*used[k]);
    ++k;
    fr.predicted_ns = fr.measured_ns * std::exp(fr.residual);
  }

  for (const auto& [name, samples] : m.costs_us)
    if (!samples.empty()) rep.costs[name] = fit_cost(samples);
  return rep;
}

// The objective of the fit with `name` held at `value` (the rest refitted); infinity when that
// fit is refused.
double objective_with(const Measurements& m, FitOptions opt, const std::string& name,
                      double value) {
  opt.fixed[name] = value;
  try {
    return fit_once(m, opt).objective;
  } catch (const RunError&) {
    return std::numeric_limits<double>::infinity();
  }
}

// The smallest value of `name` (the others refitted) whose objective exceeds the best one's by
// at most the residual variance (a profile-likelihood one-standard-error bound), searched on the
// log scale below `best` (the unconstrained fit's value).
double profile_lower_bound(const Measurements& m, const FitOptions& opt, const std::string& name,
                           double best) {
  FitOptions held = opt;
  held.fixed[name] = best;
  const FitReport at_best = fit_once(m, held);
  const double target = at_best.objective + at_best.objective / std::max(1, at_best.dof);  // + s^2
  double hi = std::log(best), lo = hi;
  // Step down by factors of e until the objective passes the target (or 40 e-folds).
  for (int i = 0; i < 40; ++i) {
    lo -= 1.0;
    if (objective_with(m, opt, name, std::exp(lo)) > target) break;
    hi = lo;
  }
  for (int i = 0; i < 12; ++i) {  // bisection to ~1e-3 of an e-fold
    const double mid = 0.5 * (lo + hi);
    (objective_with(m, opt, name, std::exp(mid)) > target ? lo : hi) = mid;
  }
  return std::exp(hi);
}

}  // namespace

FitReport fit(const Measurements& m, const FitOptions& options) {
  FitOptions opt = options;
  std::map<std::string, std::string> held;  // parameter -> why
  std::set<std::string> holding;            // profile searches under way
  // Holds the parameter `e` names (FitOptions::hold_unidentified) or rethrows it.
  std::function<void(const UnidentifiedParameter&)> hold = [&](const UnidentifiedParameter& e) {
    const std::string& name = e.parameter();
    const bool bandwidth = name.ends_with(".bandwidth_mbps");
    // A parameter whose profile search is already under way (two bandwidths each leaving the
    // other free) cannot be held this way: refuse, naming it.
    if (!opt.hold_unidentified || !bandwidth || held.count(name) || holding.count(name) ||
        options.fixed.count(name))
      throw e;
    const std::string fitted_as =
        fmt("%.4g", e.value()) +
        (std::isfinite(e.log_std_error())
             ? " with a standard error of its logarithm of " + fmt("%.3g", e.log_std_error())
             : std::string(", where the fit does not depend on it"));
    double bound = 0.0;
    holding.insert(name);
    for (;;) {
      try {
        bound = profile_lower_bound(m, opt, name, e.value());
        break;
      } catch (const UnidentifiedParameter& inner) {
        if (inner.parameter() == name) throw;
        hold(inner);  // another parameter the profile's fits leave free: hold it first
      }
    }
    opt.fixed[name] = bound;
    held[name] =
        "not identified (the co-runs show too little contention to fit it to: its "
        "best fit is " +
        fitted_as + "): held at " + fmt("%.4g", bound) +
        ", the lower end of its one-standard-error profile interval, the most "
        "contention the measurements allow";
  };
  for (;;) {
    try {
      FitReport rep = fit_once(m, opt);
      for (auto& p : rep.parameters)
        if (const auto it = held.find(p.name); it != held.end()) p.how = it->second;
      for (auto& note : rep.notes)
        for (const auto& [name, why] : held)
          if (note.rfind(name + " fixed by the caller", 0) == 0) note = name + ": " + why;
      return rep;
    } catch (const UnidentifiedParameter& e) {
      hold(e);
    }
  }
}

json fitted_platform(const Measurements& m, const FitReport& rep, std::string name) {
  const HostFacts& h = m.host;
  const SimPlatform& p = rep.platform;
  const std::string by =
      "rosguard calibrate on " + (h.hostname.empty() ? "this host" : h.hostname) + " at " + h.date;
  std::size_t used = 0;
  for (const auto& r : rep.runs)
    used += r.used ? 1 : 0;
  const std::string residual = "RMS residual " + fmt("%.1f %%", 100.0 * rep.rms_residual) +
                               " (log ratio predicted / measured ns per line) over " +
                               std::to_string(used) + " runs";
  const auto param = [&](const std::string& n) -> const FittedParameter& {
    for (const auto& q : rep.parameters)
      if (q.name == n) return q;
    throw RunError("calibration report has no parameter " + n);
  };
  const auto describe = [&](std::initializer_list<const char*> names) {
    std::string s;
    for (const char* n : names) {
      const FittedParameter& q = param(n);
      const std::string key = std::string(n).substr(std::string(n).rfind('.') + 1);
      s += (s.empty() ? "" : "; ") + key + " " +
           (q.fitted ? "fitted +- " + fmt("%.2g", q.std_error) + " (" + q.how + ")" : q.how);
    }
    return s;
  };

  json doc;
  doc["name"] = std::move(name);
  doc["description"] = "This host as measured by rosguard calibrate" +
                       (h.hostname.empty() ? std::string() : " on " + h.hostname) + " at " +
                       h.date + " (" + std::to_string(h.cpus) + " CPUs" +
                       (h.cpu_model.empty() ? std::string() : ", " + h.cpu_model) +
                       "): memory model and kernel models fitted to its measurements, costs from "
                       "its samples.";
  json cpu = {{"clusters", p.clusters},
              {"cores_per_cluster", p.cores_per_cluster},
              {"freq_mhz", p.freq_mhz},
              {"source", "host facts seen by " + by + " (rosguard platform probe)"}};
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

  // Reference: Eq. 1 (MiB/s) of bandwidth_read over 2048 KB alone, measured if the suite ran it.
  const KernelRun* ref = nullptr;
  for (const auto& r : m.runs)
    if (r.kernel == "bandwidth_read" && r.working_set_kb == 2048.0 && r.corunners.empty()) ref = &r;
  if (ref) {
    doc["reference"] = {{"mbps", round_sig(mbps_of(1.0 / ref->ns_per_line), 6)},
                        {"source",
                         "bandwidth_read (2048 KB working set, one load per 64-byte line) alone, "
                         "measured by " +
                             by + ": median of " + std::to_string(ref->samples) + " runs, cv " +
                             fmt("%.1f %%", 100.0 * ref->cv)}};
  } else {
    const double ns = predict_ns_per_line(p, {"bandwidth_read", 2048.0, {}, 0.0, 0.0, 0});
    doc["reference"] = {
        {"mbps", round_sig(mbps_of(1.0 / ns), 6)},
        {"source", "bandwidth_read (2048 KB) alone as predicted by the model fitted by " + by +
                       " (the suite did not measure 2048 KB)"}};
  }

  const auto sig = [](double v) { return round_sig(v, 5); };
  doc["memory"] = {
      {"l3",
       {{"latency_ns", sig(p.l3.latency_ns)},
        {"queue_ns", sig(p.l3.queue_ns)},
        {"bandwidth_mbps", sig(p.l3.bandwidth_mbps)},
        {"source", "fitted by " + by + ", " + residual + ": " +
                       describe({"l3.latency_ns", "l3.queue_ns", "l3.bandwidth_mbps"})}}},
      {"dram",
       {{"latency_ns", sig(p.dram.latency_ns)},
        {"queue_ns", sig(p.dram.queue_ns)},
        {"bandwidth_mbps", sig(p.dram.bandwidth_mbps)},
        {"source", "fitted by " + by + ", " + residual + ": " +
                       describe({"dram.latency_ns", "dram.queue_ns", "dram.bandwidth_mbps"})}}},
      {"mshr",
       {{"per_core", sig(p.mshr.per_core)},
        {"per_cluster", sig(p.mshr.per_cluster)},
        {"source",
         "not fitted by " + by + ": " + describe({"mshr.per_core", "mshr.per_cluster"})}}},
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
                                 describe({("kernels." + k + ".ns_per_line_l2").c_str(),
                                           ("kernels." + k + ".ns_per_line_l3").c_str(),
                                           ("kernels." + k + ".mlp").c_str()})}};
  doc["kernels"] = kernels;

  json costs = json::object();
  std::vector<std::string> missing;
  // local_message_latency is optional (older measurements, a suite on one core); the others
  // are the platform's required costs.
  for (const char* c : {"pmc_callback", "publish", "message_latency", "local_message_latency",
                        "controller_callback", "throttle_activation", "external_read"}) {
    const auto it = rep.costs.find(c);
    if (it == rep.costs.end()) {
      if (std::string(c) != "local_message_latency") missing.push_back(c);
      continue;
    }
    const CostFit& cf = it->second;
    json d = cf.distribution;
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
  doc["costs"] = costs;
  return doc;
}

json to_json(const FitReport& rep) {
  json j;
  j["converged"] = rep.converged;
  j["lm_status"] = rep.lm_status;
  j["lm_status_text"] = rep.lm_status_text;
  j["evaluations"] = rep.evaluations;
  j["iterations"] = rep.iterations;
  j["rms_residual"] = rep.rms_residual;
  j["parameters"] = json::array();
  for (const auto& p : rep.parameters)
    j["parameters"].push_back({{"name", p.name},
                               {"value", p.value},
                               {"std_error", p.std_error},
                               {"fitted", p.fitted},
                               {"how", p.how}});
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

// The sim platform model fitted to host measurements (issue 11, `rosguard calibrate`).
//
// Called by the calibrate command with what the hw suite measured (model/calibration/
// measurements.h). fit() is a maximum a posteriori (regularised) non-linear least-squares fit
// (Eigen's Levenberg-Marquardt, started from the priors' medians and from each bandwidth at a half
// and a quarter of its median, the lowest objective kept: a queue and its bandwidth trade off along
// a ridge with more than one local minimum) of the model's free parameters, on a log scale: the
// runs' relative residuals log(predicted / measured ns_per_line), each weighted by the run's
// repeatability (0.02 / max(cv, 0.02): a run whose repetitions scatter counts less), plus one
// residual per parameter for its prior (lognormal: a median and a spread, each with its source: the
// runs that show it most directly, or a typical value where the runs cannot show it). The priors
// are scaled by the runs' residual standard deviation, so a prior weighs as one measurement of its
// parameter. Every parameter is reported with its posterior standard error and how far the runs
// narrowed its prior (data_share); one the runs narrowed by less than half is prior-dominated: a
// note says so, and the model is still written. Predictions are exactly the sim's: the kernel's
// profile (sim/workload/profile.h: kernel_profile) on the memory model's steady state
// (sim/platform/contention.h), the measured kernel on core 0 and co-runner k on core k + 1.
// Placement: the fit runs twice where the host's probed clusters have more than one core, once on
// them (the co-runners share the measured core's L3) and once with each core in a cluster of its
// own (each its own L3, the DRAM shared), and keeps the one with the lower RMS residual, with a
// note giving both (FitOptions::placement fixes one): a VM's vCPUs share the L3 its sysfs reports
// only while the host runs them on one L3 (on the AMD EPYC VM of 2026-11-28 a 4 MB pointer chase
// beside a 128 MB stream took 137-159 ns per load in some calibrations, 16-24 ns, as alone, in
// others). The model written has the chosen clusters. Co-runs whose block's contention probes
// (KernelRun::probes) are not in the suite's DRAM-interference state (calibration::contention_state
// of its probes) are left out, each with a note: the model describes one state, and a block the
// suite could not measure in it (the host kept the vCPUs elsewhere longer than the suite waits)
// would pull the DRAM parameters towards another.
//
// Parameters (all strictly positive: fitted as logarithms, which keeps them in bounds):
//   fitted: per kernel ns_per_line_l2 (isolation within the L2), ns_per_line_l3 (isolation within
//     the L3), mlp (runs beyond the L3, given the DRAM latency); l3.queue_ns and
//     l3.bandwidth_mbps (co-runs within the L3); dram.latency_ns (the latency kernel beyond the
//     L3); dram.queue_ns and dram.bandwidth_mbps (co-runs beyond the L3); dram.writeback_weight
//     (co-runs beyond the L3 with a writing kernel: held at 1 without one; at most 4, the platform
//     schema's range: where the runs push it beyond, it is held at 4, noted, and the rest fitted
//     again; FitOptions::strict refuses such a fit). With one co-runner
//     count the runs cannot separate a queue from its bandwidth: the queue's prior (the level's
//     unloaded latency) decides between them. Runs whose working sets together overflow the L3
//     are predicted by the shared-LRU model (no parameter).
//   fixed or derived: kernels.latency.mlp = 1 (a pointer chase has one load in flight);
//     l3.latency_ns = the fitted kernels.latency.ns_per_line_l3 (the model only uses latencies
//     above it, so no time measurement can identify it; the pointer chase within the L3 is its
//     load-to-use latency); mshr.per_core and mshr.per_cluster = FitOptions::mshr_per_core and
//     mshr_per_cluster (the runs cannot tell a kernel's mlp from the buffers' bound: held where
//     they do not bind); anything named in FitOptions::fixed.
//
// Contract: pure C++ (no SystemC, no OS calls). fit() throws RunError naming what is missing
// when the runs lack a kernel's own speed within the L2 or the L3 (no prior stands in for
// those), RunError with the LM status when the fit does not converge or the RMS residual exceeds
// FitOptions::max_rms_residual (the runs contradict the model or each other), and
// UnidentifiedParameter for a prior-dominated parameter when FitOptions::strict is set.
#pragma once

#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "calibration/measurements.h"
#include "core/error.h"
#include "platform/sim_platform.h"

namespace rosguard::calibration {

// Where the model puts the cores beside the measured one (fit()): Best fits both of the others
// and keeps the one with the lower RMS residual; AsProbed: the host's clusters as probed (the
// co-runners in the measured core's cluster, sharing its L3); Apart: each core in a cluster of its
// own (its own L3, the DRAM shared).
enum class Placement { Best, AsProbed, Apart };

struct FitOptions {
  // LM residual evaluations per solve (each one predicts every run); 0: MINPACK's default for
  // lmder, 100 x (free parameters + 1).
  int max_evaluations = 0;
  double max_rms_residual = 0.5;  // refuse a fit worse than this (log units: 0.5 is ~65 %)
  // A fitted parameter whose prior the runs narrowed by less than this share of its variance is
  // prior-dominated.
  double min_data_share = 0.5;
  // The misses-in-flight bounds, held where they do not bind (the platform schema's largest
  // values): a kernel's fitted mlp stays below the core's, and no co-run reaches the cluster's.
  double mshr_per_core = 1024.0;
  double mshr_per_cluster = 4096.0;
  // Parameters held at a given value instead of fitted, by their report name
  // ("l3.queue_ns", "kernels.bandwidth_read.mlp", ...). Reported as fixed.
  std::map<std::string, double> fixed;
  // Refuse a fit with a prior-dominated parameter (UnidentifiedParameter) instead of writing it
  // (`rosguard calibrate --strict`).
  bool strict = false;
  Placement placement = Placement::Best;
};

// fit() refuses (FitOptions::strict): the runs leave `parameter` to its prior (the standard error
// of its logarithm `log_std_error` at the fitted `value`).
class UnidentifiedParameter : public RunError {
 public:
  UnidentifiedParameter(const std::string& message, std::string parameter, double value,
                        double log_std_error)
      : RunError(message),
        parameter_(std::move(parameter)),
        value_(value),
        log_std_error_(log_std_error) {}
  const std::string& parameter() const { return parameter_; }
  double value() const { return value_; }
  double log_std_error() const { return log_std_error_; }

 private:
  std::string parameter_;
  double value_;
  double log_std_error_;
};

struct FittedParameter {
  std::string name;  // "dram.latency_ns", "kernels.bandwidth_read.mlp"
  double value = 0.0;
  double std_error = 0.0;      // posterior, in the parameter's units (delta method from the log
                               // scale); 0 if not fitted
  double log_std_error = 0.0;  // posterior standard error of its logarithm
  bool fitted = false;         // false: fixed or derived (see `how`)
  std::string how;             // what identifies it, or why and from what it is fixed
  // Fitted parameters: the prior (lognormal median and spread of the logarithm, its source), the
  // share of the prior's variance the runs removed, and whether that is below
  // FitOptions::min_data_share.
  double prior_median = 0.0;
  double prior_log_sd = 0.0;
  std::string prior_source;
  double data_share = 1.0;
  bool prior_dominated = false;
  // Held at the end of its range (the platform schema's), where the runs pushed it beyond.
  bool at_bound = false;
};

struct FittedRun {
  std::size_t index = 0;     // into Measurements::runs
  std::string label;         // "bandwidth_read 2048 KB + bandwidth_read 2048 KB"
  double measured_ns = 0.0;  // ns per line
  double predicted_ns = 0.0;
  double residual = 0.0;  // log(predicted / measured)
  bool used = false;      // false: not modelled (see note), not in the fit
  std::string note;
};

struct CostFit {
  nlohmann::json distribution;  // the platform "costs" entry, without its source
  std::size_t samples = 0;
  double min_us = 0.0, median_us = 0.0, p90_us = 0.0, max_us = 0.0;
};

struct FitReport {
  sim::SimPlatform platform;  // the fitted model (memory, kernels; no costs): predicts with it
  std::vector<FittedParameter> parameters;
  std::vector<FittedRun> runs;
  std::map<std::string, CostFit> costs;  // by cost name ("publish", ...): from costs_us
  double rms_residual = 0.0;             // over the used runs, log units, weighted (weight_of)
  double data_ssr = 0.0;                 // the used runs' weighted sum of squared log residuals
  int lm_status = 0;                     // Eigen's LevenbergMarquardtSpace::Status
  std::string lm_status_text;
  double objective = 0.0;  // the sum of squared residuals (runs and priors) at the solution
  int dof = 0;             // used runs minus fitted parameters (at least 1)
  int evaluations = 0;
  int iterations = 0;
  bool converged = false;
  std::vector<std::string> notes;  // placement, fixed parameters, runs left out, prior-dominated
                                   // values
  // The placement the model describes ("probed": the host's clusters; "apart": each core its own
  // cluster) and the RMS residual each placement fitted with (NaN: not tried, or refused).
  std::string placement = "probed";
  double rms_probed = 0.0, rms_apart = 0.0;
};

// The model's skeleton for `host`: CPU, caches (L2, L3 capacity), and placeholder memory
// parameters (orin-agx's defaults); no kernels, no costs.
sim::SimPlatform model_platform(const HostFacts& host);

// ns per line of `run` predicted by `platform` (which must model the run's kernels): the sim's
// profile and steady state. Throws RunError for a kernel without a model or more co-runners than
// the cluster has other cores.
double predict_ns_per_line(const sim::SimPlatform& platform, const KernelRun& run);

// The fit (see above). Costs: each costs_us entry with samples becomes a distribution (fit_cost;
// "preemption": fit_mean_cost).
FitReport fit(const Measurements& measurements, const FitOptions& options = {});

// A cost distribution from raw samples (us): a shifted lognormal through the samples' 10th, 50th
// and 90th percentiles (its location clamped to [0, smallest sample]), clipped at the largest;
// a normal through the same percentiles (mean the median, sd (p90 - p10) / 2.563), truncated to
// the samples' range, when they are not right-skewed (so that a far outlier, e.g. a wake-up that
// RT throttling delayed, widens neither); a constant when every sample is equal. Throws RunError
// without samples.
CostFit fit_cost(std::vector<double> samples_us);
// A cost whose samples are each a mean over many events, not single events (costs_us
// "preemption": one per pair of timed windows): a constant at their median, at least 0 (a pair
// may find the stream faster beside the wake-ups than alone: noise). Throws RunError without
// samples.
CostFit fit_mean_cost(std::vector<double> samples_us);

// A full platform document (validates against platform.schema.json, runs in sim): cpu and
// caches from the host facts, memory and kernels from the fit, costs from the samples, reference
// = the measured bandwidth_read 2048 KB isolation bandwidth; every "source" says what was fitted
// on which host and when, with what residual. Throws RunError when a cost has no samples.
nlohmann::json fitted_platform(const Measurements& measurements, const FitReport& report,
                               std::string name);

// The uncertainty band of a fitted platform: for each prior-dominated parameter of `report`, two
// copies of `platform` (fitted_platform()'s document) with that parameter one posterior standard
// error lower and higher (value / exp(log_std_error), value x exp(log_std_error)), named
// "<name>-<parameter>-low" / "-high" with a description saying so. A sim run on each (one
// parameter at a time) bounds how far the prior-dominated parameters move a prediction; the
// envelope of those runs and the nominal one is the band `make validate` and `rosguard compare
// --band` show. Empty when nothing is prior-dominated.
std::vector<std::pair<std::string, nlohmann::json>> band_platforms(const nlohmann::json& platform,
                                                                   const FitReport& report);

// The report as the "fit" object of calibration.json.
nlohmann::json to_json(const FitReport& report);

}  // namespace rosguard::calibration

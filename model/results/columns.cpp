#include "results/columns.h"

#include <cctype>

namespace rosguard {
namespace {

// Per-node columns: the first RT / nRT node's have the prefix "rt_" / "nrt_" ("rt_time_us",
// "nrt_throttled_us"), the others an index ("rt1_time_us", "nrt2_throttled_us"); their meanings
// are the same.
const std::vector<ColumnInfo>& rt_node_columns() {
  static const std::vector<ColumnInfo> c = {
      {"workload", "text", "the RT node's workload"},
      {"name", "text", "the RT node's name (nodes.rt[i].name in the scenario)"},
      {"core", "count", "the core the RT node runs on"},
      {"time_us", "us", "the RT node's job time in the co-run (median over its jobs)"},
      {"isolation_us", "us",
       "the same job alone on the same core, unregulated (median of the baseline measurements; "
       "with hw.adjacent_baselines the measurement taken right before this repetition)"},
      {"slowdown", "ratio", "time_us / isolation_us (1.0 = as fast as alone)"},
      {"isolation_n", "count", "isolation measurements behind isolation_us"},
      {"isolation_cv", "ratio", "coefficient of variation of those measurements"},
      {"response_p99_us", "us", "99th percentile of the job response times (release to end)"},
      {"response_max_us", "us", "largest job response time"},
      {"deadline_misses", "count", "jobs that ended after their deadline (periodic RT nodes)"},
      {"slowdown_ci95_pct", "%",
       "half-width of the 95 % confidence interval (Student t) of the point's mean slowdown over "
       "its repetitions, in percent of that mean: each repetition's co-run time over the "
       "baseline measured in the same round (hw; empty in sim and with one repetition)"},
      {"unregulated_time_us", "us",
       "the RT node's job time in the unregulated co-run: the same nodes with policy none, "
       "measured once per distinct co-run (median over its measurements; a point with policy "
       "none: its own time_us; empty with rosguard run --no-unregulated)"},
      {"unregulated_slowdown", "ratio",
       "unregulated_time_us / isolation_us: the RT node's slowdown without regulation"},
  };
  return c;
}

const std::vector<ColumnInfo>& nrt_node_columns() {
  static const std::vector<ColumnInfo> c = {
      {"workload", "text", "the nRT node's workload"},
      {"name", "text", "the nRT node's name (nodes.nrt[i].name in the scenario)"},
      {"core", "count", "the core the nRT node runs on"},
      {"time_us", "us", "time the nRT node took for the work it did in isolation_us alone"},
      {"isolation_us", "us",
       "one run of the nRT workload alone on the same core, unregulated (median; with "
       "hw.adjacent_baselines the measurement taken right before this repetition)"},
      {"slowdown", "ratio", "time_us / isolation_us over the same work (1.0 = as fast as alone)"},
      {"isolation_n", "count", "isolation measurements behind isolation_us"},
      {"isolation_cv", "ratio", "coefficient of variation of those measurements"},
      {"bandwidth_mbps", "MiB/s",
       "the nRT node's Eq. 1 bandwidth while regulation is active (64 B x L2 refills and "
       "write-backs / time, divided by 1024^2)"},
      {"throttle_count", "count", "times the nRT node's core was throttled"},
      {"throttled_us", "us", "total time the nRT node's core spent throttled"},
      {"slowdown_ci95_pct", "%",
       "half-width of the 95 % confidence interval (Student t) of the point's mean slowdown over "
       "its repetitions, in percent of that mean: each repetition's co-run time over the "
       "baseline measured in the same round (hw; empty in sim and with one repetition)"},
      {"unregulated_time_us", "us",
       "the nRT node's time for one run in the unregulated co-run (as time_us; a point with "
       "policy none: its own time_us; empty with rosguard run --no-unregulated)"},
      {"unregulated_slowdown", "ratio",
       "unregulated_time_us / isolation_us: the nRT node's slowdown without regulation"},
  };
  return c;
}

std::vector<ColumnInfo> build_points() {
  std::vector<ColumnInfo> d = {
      {"point", "text",
       "stable id of the point's parameters (resumed and sharded runs merge on it)"},
      {"rep", "count", "repetition index, from 0"},
      {"backend", "text", "sim or hw"},
      {"rt_workload", "text", "the first RT node's workload"},
      {"nrt_workload", "text", "the first nRT node's workload"},
      {"policy", "text",
       "regulation policy (none, interval, monolithic, monitor, memguard, mempol)"},
      {"sampling", "text",
       "the sampling the point ran with: self (each nRT node samples its own counters), "
       "external (the controller reads them), overflow (a PMU overflow interrupt on the nRT "
       "core: memguard) or mmio (the controller polls debug registers: mempol); where the "
       "backend could not run the scenario's, what it ran instead (the manifest's fallbacks "
       "say why)"},
      {"scope", "text", "what one budget covers: core, node or group (all nRT nodes)"},
      {"threshold_pct", "%",
       "bandwidth setpoint as a percentage of the reference bandwidth (unused where "
       "regulation.budget_mbps is given: the manifest's scenario has it)"},
      {"sampling_period_us", "us", "PMC sampling period the point ran with"},
      {"regulation_period_us", "us", "regulation (budget) period"},
  };
  const auto node = [&](const std::string& prefix, const std::vector<ColumnInfo>& cols,
                        const char* skip) {
    for (const auto& c : cols)
      if (c.name != skip) d.push_back({prefix + c.name, c.unit, c.meaning});
  };
  node("rt_", rt_node_columns(), "workload");
  node("nrt_", nrt_node_columns(), "workload");
  // The fixed names of the first nRT node's throttle columns (DESIGN section 7).
  d.push_back({"throttle_count", "count",
               "times the first nRT node's core was throttled (the same as nrt_throttle_count)"});
  d.push_back({"throttled_us", "us",
               "total time the first nRT node's core spent throttled (the same as "
               "nrt_throttled_us)"});
  const std::vector<ColumnInfo> rest = {
      {"activation_delay_p50_us", "us",
       "median delay from the sample that exhausted a budget to the throttle taking hold"},
      {"activation_delay_max_us", "us", "largest such delay"},
      {"pmc_callback_p50_us", "us", "median duration of the PMC sampling callback"},
      {"pmc_callback_max_us", "us", "longest PMC sampling callback"},
      {"rt_isolation_ipc", "IPC", "the first RT workload's instructions per cycle alone"},
      {"rt_isolation_mbps", "MiB/s", "the first RT workload's Eq. 1 bandwidth alone"},
      {"nrt_isolation_ipc", "IPC", "the first nRT workload's instructions per cycle alone"},
      {"nrt_isolation_mbps", "MiB/s", "the first nRT workload's Eq. 1 bandwidth alone"},
      {"platform", "text", "platform name"},
      {"nrt_mode", "text", "loop (the nRT workload restarts until the RT nodes finish) or once"},
      {"rt_jobs", "count", "RT jobs completed in the run"},
      {"nrt_runs", "count", "whole nRT runs completed in the run"},
      {"reference_mbps", "MiB/s", "the reference bandwidth threshold_pct is a share of"},
      {"sampling_overhead_p50_us", "us",
       "median time a self-sampling callback took from its nRT node"},
      {"signal_latency_p50_us", "us",
       "median delay of an RT enable / disable signal from its publish to the controller (hw)"},
      {"signal_to_thr_p50_us", "us",
       "median delay from an RT enable signal's publish to the first throttle (hw)"},
  };
  d.insert(d.end(), rest.begin(), rest.end());
  node("rt<i>_", rt_node_columns(), "");
  node("nrt<i>_", nrt_node_columns(), "");
  d.push_back({"param:<path>", "as swept",
               "the value of a swept scenario path at this point (one column per sweep path)"});
  return d;
}

}  // namespace

const std::vector<ColumnInfo>& point_column_dictionary() {
  static const std::vector<ColumnInfo> d = build_points();
  return d;
}

const std::vector<ColumnInfo>& sample_kind_dictionary() {
  static const std::vector<ColumnInfo> d = {
      {"activation_delay", "us",
       "one delay from the sample that exhausted a budget to the throttle (overflow sampling: "
       "from the counter crossing the budget; on hw from the overflow signal's handler)"},
      {"pmc_callback", "us", "one PMC sampling callback's duration (mmio sampling: one poll)"},
      {"overflow_irq", "us",
       "overflow sampling (sim): one PMU overflow interrupt, crossing to the throttle taking "
       "hold"},
      {"pmc_read", "us", "one read of the counters inside a callback"},
      {"sampling_overhead", "us", "time one self-sampling callback took from its nRT node"},
      {"rt_job", "us", "one job of the first RT node, release to end"},
      {"rt<i>_job", "us", "one job of RT node i (i >= 1), release to end"},
      {"signal_latency", "us", "one RT enable / disable signal, publish to controller (hw)"},
      {"signal_to_thr", "us", "one RT enable signal's publish to the first throttle (hw)"},
  };
  return d;
}

std::optional<ColumnInfo> describe_point_column(const std::string& name) {
  for (const auto& c : point_column_dictionary())
    if (c.name == name) return c;
  if (name.rfind("param:", 0) == 0) {
    ColumnInfo c = point_column_dictionary().back();
    c.name = name;
    return c;
  }
  // "rt3_slowdown" -> the "rt<i>_slowdown" entry.
  for (const char* prefix : {"nrt", "rt"}) {
    const std::string p(prefix);
    if (name.rfind(p, 0) != 0) continue;
    std::size_t i = p.size();
    while (i < name.size() && std::isdigit(static_cast<unsigned char>(name[i])))
      ++i;
    if (i == p.size() || i >= name.size() || name[i] != '_') continue;
    for (const auto& c : point_column_dictionary())
      if (c.name == p + "<i>" + name.substr(i)) return ColumnInfo{name, c.unit, c.meaning};
  }
  return std::nullopt;
}

}  // namespace rosguard

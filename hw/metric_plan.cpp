// How the regulation metric is measured on this host (hw/metric_plan.h).
#include "hw/metric_plan.h"

#include "core/error.h"

namespace rosguard::hw {

namespace {

void map_metric(const Scenario& s, const PmcSourceRegistry& sources, MetricPlan& plan);

}  // namespace

MetricPlan plan_metric(const Scenario& s, const PmcSourceRegistry& sources) {
  const auto& wanted = s.regulation.metric.events;
  bool all_builtin = true;
  std::size_t first_command = 0;
  for (std::size_t i = 0; i < s.nodes.nrt.size(); ++i)
    if (s.nodes.nrt[i].workload.is_command() && all_builtin) {
      all_builtin = false;
      first_command = i;
    }
  const auto make = [&](const std::string& name) { return sources.find(name)->make(); };
  // The metric's events `src` does not count here, named ("" if none).
  const auto missing = [&](const PmcSource& src) {
    std::string out;
    for (const auto& e : wanted)
      if (!src.provides(e.name)) out += (out.empty() ? "" : ", ") + e.name;
    return out;
  };

  MetricPlan plan;
  switch (s.hw.pmc_source) {
    case PmcSourceKind::Perf: {
      auto src = make("perf");
      if (auto why = src->unavailable_reason())
        throw InputError(s.file, "/hw/pmc_source",
                         "pmc_source \"perf\" cannot count hardware events on this host: " + *why +
                             "; use \"auto\", \"instrumented\" or \"software\"");
      for (const auto& e : wanted)
        if (!src->provides(e.name))
          throw InputError(s.file, "/regulation/metric/events/" + e.name,
                           "the perf source has no event '" + e.name + "' on this host");
      plan.source = "perf";
      plan.why = "requested";
      break;
    }
    case PmcSourceKind::Instrumented: {
      if (!all_builtin)
        throw InputError(s.file, "/nodes/nrt/" + std::to_string(first_command) + "/workload",
                         "pmc_source \"instrumented\" counts only built-in workloads, and this "
                         "nRT node runs an external command; use \"auto\", \"software\" or "
                         "\"perf\"");
      auto src = make("instrumented");
      for (const auto& e : wanted)
        if (!src->provides(e.name))
          throw InputError(s.file, "/regulation/metric/events/" + e.name,
                           "the instrumented source counts l2d_cache_refill and l2d_cache_wb "
                           "only, not '" +
                               e.name + "'");
      plan.source = "instrumented";
      plan.why = "requested";
      break;
    }
    case PmcSourceKind::Software:
      plan.source = "software";
      plan.why = "requested";
      break;
    case PmcSourceKind::Auto: {
      auto perf = make("perf");
      const auto perf_why = perf->unavailable_reason();
      const std::string perf_lacks = perf_why ? std::string() : missing(*perf);
      if (!perf_why && perf_lacks.empty()) {
        plan.source = "perf";
        plan.why = "auto: the hardware PMU works";
        break;
      }
      const std::string no_pmu =
          "auto: no usable hardware PMU (" +
          (perf_why ? *perf_why : "it does not count the metric's " + perf_lacks) + ")";
      const std::string instrumented_lacks = missing(*make("instrumented"));
      if (all_builtin && instrumented_lacks.empty()) {
        plan.source = "instrumented";
        plan.why = no_pmu + "; every nRT workload is built in";
      } else {
        plan.source = "software";
        plan.why = no_pmu + (all_builtin ? "; the instrumented source does not count the "
                                           "metric's " +
                                               instrumented_lacks
                                         : " and an nRT workload is an external command");
      }
      break;
    }
  }
  map_metric(s, sources, plan);
  return plan;
}

namespace {

// Maps the scenario's metric onto the chosen source (plan.source).
void map_metric(const Scenario& s, const PmcSourceRegistry& sources, MetricPlan& plan) {
  const auto& wanted = s.regulation.metric.events;
  plan.spec = s.regulation.metric;
  if (plan.source == "software") {
    if (auto why = sources.find("software")->make()->unavailable_reason())
      throw InputError(s.file, "/hw/pmc_source", "perf software events do not work here: " + *why);
    // Time-based budget: bytes = task_clock ns x reference bytes per ns. The nRT node may then
    // run threshold% of each regulation period while an RT node runs.
    plan.group_events = software_group_events();
    plan.metric_events = 1;
    const double bytes_per_ns = s.regulation.reference_mbps * kBytesPerMb / 1e9;
    plan.spec.events = {{"task_clock", bytes_per_ns / plan.spec.line_bytes}};
    plan.spec.counter_bits = 64;
    plan.time_based = true;
    plan.basis = "time-based budget: bytes = task_clock ns x reference_mbps (" +
                 std::to_string(s.regulation.reference_mbps) + " MB/s)";
    std::string names;
    for (const auto& e : wanted)
      names += (names.empty() ? "" : ", ") + e.name;
    plan.fallback = "the software source has no bandwidth events (" + names +
                    "): regulating with a time-based budget, bytes = task_clock x reference_mbps";
  } else {
    for (const auto& e : wanted)
      plan.group_events.push_back(e.name);
    plan.metric_events = plan.group_events.size();
    if (plan.source == "instrumented") {
      plan.spec.counter_bits = 64;
      plan.basis =
          "instrumented: lines touched by the built-in kernels (reads -> l2d_cache_refill, "
          "writes -> l2d_cache_refill + l2d_cache_wb) x line_bytes; Eq. 1 with cycles = elapsed "
          "time x frequency";
    } else {
      plan.spec.counter_bits = 64;  // perf_event_open accumulates into 64-bit values
      plan.basis = "perf hardware events, Eq. 1";
    }
  }
}

}  // namespace
}  // namespace rosguard::hw

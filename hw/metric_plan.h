// The metric plan: which PMC source measures the regulation metric for a scenario on this host,
// and how the scenario's metric maps onto it.
//
// Contract: pure apart from probing the sources (perf_event_open); any thread.
#pragma once

#include <string>
#include <vector>

#include "hw/pmc_source/pmc_source.h"
#include "metric/metric.h"
#include "scenario/scenario.h"

namespace rosguard::hw {

// How the regulation metric is measured on this host for a scenario.
struct MetricPlan {
  std::string source;                     // perf | software | instrumented
  std::string why;                        // how it was chosen (auto) or "requested"
  std::vector<std::string> group_events;  // opened per nRT entity; the metric's first
  std::size_t metric_events = 0;
  MetricSpec spec;          // what the regulator is given
  bool time_based = false;  // software source: bytes estimated from task_clock
  std::string basis;        // human-readable description of the metric
  std::string fallback;     // non-empty: the scenario's metric could not be measured as written
};

// Chooses the source (hw.pmc_source; auto: perf if the hardware PMU works, else instrumented when
// every nRT workload is built in, else software) and maps the scenario's metric onto it. Throws
// InputError when an explicitly requested source cannot serve the scenario.
MetricPlan plan_metric(const Scenario& s, const PmcSourceRegistry& sources);

// `policies` (the run's registry) must outlive the backend.
}  // namespace rosguard::hw

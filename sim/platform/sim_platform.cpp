#include "platform/sim_platform.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace rosguard::sim {
namespace {

using json = nlohmann::json;

Distribution parse_distribution(const json& j, const std::string& file, const std::string& path) {
  Distribution d;
  const std::string kind = j.at("dist").get<std::string>();
  const auto fail = [&](const std::string& msg) { throw InputError(file, path, msg); };
  if (kind == "constant") {
    d.kind = Distribution::Kind::Constant;
    d.value_us = j.at("value_us").get<double>();
  } else if (kind == "uniform") {
    d.kind = Distribution::Kind::Uniform;
    d.min_us = j.at("min_us").get<double>();
    d.max_us = j.at("max_us").get<double>();
    if (d.max_us < d.min_us) fail("max_us is below min_us");
  } else if (kind == "normal") {
    d.kind = Distribution::Kind::Normal;
    d.mean_us = j.at("mean_us").get<double>();
    d.spread = j.at("sd_us").get<double>();
    d.min_us = j.value("min_us", 0.0);
    d.max_us = j.value("max_us", -1.0);
    if (d.max_us >= 0 && (d.mean_us > d.max_us || d.mean_us < d.min_us))
      fail("mean_us must lie in [min_us, max_us]");
  } else {
    d.kind = Distribution::Kind::Lognormal;
    d.mean_us = j.at("median_us").get<double>();
    d.spread = j.at("sigma").get<double>();
    d.min_us = j.value("min_us", 0.0);
    d.max_us = j.value("max_us", -1.0);
    if (d.mean_us <= d.min_us) fail("median_us must be above min_us (the location)");
    if (d.max_us >= 0 && d.max_us < d.mean_us) fail("max_us must not be below median_us");
  }
  return d;
}

}  // namespace

double Distribution::mean() const {
  switch (kind) {
    case Kind::Constant:
      return value_us;
    case Kind::Uniform:
      return 0.5 * (min_us + max_us);
    case Kind::Normal:
      return mean_us;
    case Kind::Lognormal:
      return min_us + (mean_us - min_us) * std::exp(0.5 * spread * spread);
  }
  return 0.0;
}

double Distribution::upper_bound() const {
  switch (kind) {
    case Kind::Constant:
      return value_us;
    case Kind::Uniform:
      return max_us;
    case Kind::Normal:
      return max_us >= 0 ? max_us : mean_us + 6.0 * spread;
    case Kind::Lognormal:
      return max_us >= 0 ? max_us : min_us + (mean_us - min_us) * std::exp(6.0 * spread);
  }
  return 0.0;
}

const std::vector<std::string>& sim_pmu_events() {
  static const std::vector<std::string> events = {"cpu_cycles",       "inst_retired",
                                                  "l2d_cache_refill", "l2d_cache_wb",
                                                  "l3d_cache",        "l3d_cache_refill"};
  return events;
}

SimPlatform parse_sim_platform(const PlatformInfo& p) {
  const std::string& file = p.origin;
  const json& doc = p.doc;
  SimPlatform s;
  s.name = p.name;
  s.origin = p.origin;
  s.clusters = p.clusters;
  s.cores_per_cluster = p.cores_per_cluster;
  s.freq_mhz = p.freq_mhz;
  s.line_bytes = p.line_bytes;
  s.pmu_events = p.pmu_events;

  for (const auto& e : p.pmu_events)
    if (std::find(sim_pmu_events().begin(), sim_pmu_events().end(), e) == sim_pmu_events().end()) {
      std::string known;
      for (const auto& k : sim_pmu_events())
        known += (known.empty() ? "" : ", ") + k;
      throw InputError(
          file, "/pmu/events",
          "event '" + e + "' is not counted by the sim backend's PMU (it counts: " + known + ")");
    }

  if (!doc.contains("memory"))
    throw InputError(file, "/memory",
                     "the sim backend needs a memory model (\"memory\": l3, dram, core); see "
                     "scenarios/platforms/orin-agx.json");
  if (!doc.contains("costs"))
    throw InputError(file, "/costs",
                     "the sim backend needs the middleware / OS cost distributions (\"costs\"); "
                     "see scenarios/platforms/orin-agx.json");
  const auto& caches = doc.at("caches");
  if (!caches.contains("l3_kb_per_cluster"))
    throw InputError(file, "/caches/l3_kb_per_cluster",
                     "the sim backend needs the L3 capacity per cluster");
  const auto& mem = doc.at("memory");
  const auto& l3 = mem.at("l3");
  s.l3.capacity_kb = caches.at("l3_kb_per_cluster").get<double>();
  s.l3.latency_ns = l3.at("latency_ns").get<double>();
  s.l3.queue_ns = l3.at("queue_ns").get<double>();
  s.l3.bandwidth_mbps = l3.at("bandwidth_mbps").get<double>();
  s.l3.exclusive_of_l2 = l3.value("exclusive_of_l2", false);
  const auto& dram = mem.at("dram");
  s.dram.latency_ns = dram.at("latency_ns").get<double>();
  s.dram.queue_ns = dram.at("queue_ns").get<double>();
  s.dram.bandwidth_mbps = dram.at("bandwidth_mbps").get<double>();
  s.dram.writeback_weight = dram.value("writeback_weight", 1.0);
  if (mem.contains("slc")) {
    const auto& slc = mem.at("slc");
    s.slc = SlcParams{slc.at("size_kb").get<double>(), slc.at("latency_ns").get<double>()};
  }
  s.mshr.per_core = mem.at("mshr").at("per_core").get<double>();
  s.mshr.per_cluster = mem.at("mshr").at("per_cluster").get<double>();
  if (s.mshr.per_cluster < s.mshr.per_core)
    throw InputError(file, "/memory/mshr/per_cluster",
                     "a cluster cannot have fewer refills in flight than one of its cores");
  s.core.callback_ipc = mem.at("core").at("callback_ipc").get<double>();
  s.core.idle_loop_ipc = mem.at("core").at("idle_loop_ipc").get<double>();

  const auto& costs = doc.at("costs");
  const auto dist = [&](const char* key) {
    return parse_distribution(costs.at(key), file, std::string("/costs/") + key);
  };
  s.costs.pmc_callback = dist("pmc_callback_us");
  s.costs.publish = dist("publish_us");
  s.costs.message_latency = dist("message_latency_us");
  if (costs.contains("local_message_latency_us"))
    s.costs.local_message_latency = dist("local_message_latency_us");
  s.costs.controller_callback = dist("controller_callback_us");
  if (costs.contains("controller_callback_local_us"))
    s.costs.controller_callback_local = dist("controller_callback_local_us");
  s.costs.throttle_activation = dist("throttle_activation_us");
  s.costs.external_read = dist("external_read_us");
  if (costs.contains("timer_wakeup_us")) s.costs.timer_wakeup = dist("timer_wakeup_us");
  if (costs.contains("preemption_us")) s.costs.preemption = dist("preemption_us");
  if (costs.contains("overflow_irq_us")) s.costs.overflow_irq = dist("overflow_irq_us");
  if (costs.contains("mmio_poll_us")) s.costs.mmio_poll = dist("mmio_poll_us");

  s.l2_kb = caches.at("l2_kb").get<double>();
  if (doc.contains("kernels"))
    for (const auto& [name, k] : doc.at("kernels").items()) {
      if (!k.is_object()) continue;  // the kernels object's own "source"
      KernelModel m;
      m.ns_per_line_l2 = k.at("ns_per_line_l2").get<double>();
      m.ns_per_line_l3 = k.at("ns_per_line_l3").get<double>();
      m.mlp = k.at("mlp").get<double>();
      s.kernels.emplace(name, m);
    }
  return s;
}

}  // namespace rosguard::sim

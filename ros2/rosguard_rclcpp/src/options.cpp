#include "rosguard_rclcpp/options.hpp"

#include <stdexcept>

namespace rosguard_rclcpp {
namespace {

[[noreturn]] void bad(const std::string& parameter, const std::string& value,
                      const std::string& expected) {
  throw std::invalid_argument("parameter rosguard." + parameter + " = " + value + ": " + expected);
}

void one_of(const std::string& parameter, const std::string& value,
            const std::vector<std::string>& allowed) {
  for (const auto& a : allowed)
    if (a == value) return;
  std::string list;
  for (const auto& a : allowed)
    list += (list.empty() ? "" : ", ") + a;
  bad(parameter, "'" + value + "'", "expected one of " + list);
}

std::int64_t positive(const std::string& parameter, std::int64_t v) {
  if (v <= 0) bad(parameter, std::to_string(v), "expected a positive integer");
  return v;
}

template <class T>
T declare(rclcpp::Node& node, const std::string& name, const T& fallback) {
  const std::string full = "rosguard." + name;
  if (!node.has_parameter(full)) node.declare_parameter<T>(full, fallback);
  return node.get_parameter(full).get_value<T>();
}

}  // namespace

rosguard::Sampling parse_sampling(const std::string& parameter, const std::string& value) {
  if (value == "self") return rosguard::Sampling::Self;
  if (value == "external") return rosguard::Sampling::External;
  bad(parameter, "'" + value + "'",
      "expected self or external (overflow and mmio sampling are the hw backend's)");
}

NrtGuardOptions declare_nrt_options(rclcpp::Node& node) {
  NrtGuardOptions o;
  o.name = declare<std::string>(node, "name", node.get_name());
  o.ns = declare<std::string>(node, "namespace", "");
  o.core = static_cast<int>(declare<std::int64_t>(node, "core", -1));
  if (o.core < 0) bad("core", std::to_string(o.core), "the nRT node's core is required (>= 0)");
  o.sampling = parse_sampling("sampling", declare<std::string>(node, "sampling", "self"));
  o.sampling_period_us =
      positive("sampling_period_us", declare<std::int64_t>(node, "sampling_period_us", 1000));
  o.pmc_source = declare<std::string>(node, "pmc_source", "auto");
  one_of("pmc_source", o.pmc_source, {"auto", "perf", "instrumented", "software"});
  o.throttle = declare<std::string>(node, "throttle", "auto");
  one_of("throttle", o.throttle, {"auto", "fifo", "idle"});
  o.watchdog_ms = positive("watchdog_ms", declare<std::int64_t>(node, "watchdog_ms", 100));
  o.events = declare<std::vector<std::string>>(node, "events", o.events);
  return o;
}

ControllerOptions declare_controller_options(rclcpp::Node& node) {
  ControllerOptions o;
  o.ns = declare<std::string>(node, "namespace", "");
  o.core = static_cast<int>(declare<std::int64_t>(node, "core", -1));
  o.rt_nodes = declare<std::vector<std::string>>(node, "rt_nodes", {});
  o.nrt_nodes = declare<std::vector<std::string>>(node, "nrt_nodes", {});
  if (o.nrt_nodes.empty()) bad("nrt_nodes", "[]", "name at least one nRT node");
  o.nrt_cores = declare<std::vector<std::int64_t>>(node, "nrt_cores", {});
  o.policy = declare<std::string>(node, "policy", "interval");
  o.sampling = parse_sampling("sampling", declare<std::string>(node, "sampling", "self"));
  o.sampling_period_us =
      positive("sampling_period_us", declare<std::int64_t>(node, "sampling_period_us", 1000));
  o.regulation_period_us =
      positive("regulation_period_us", declare<std::int64_t>(node, "regulation_period_us", 5000));
  o.threshold_pct = declare<double>(node, "threshold_pct", 20.0);
  if (!(o.threshold_pct > 0.0 && o.threshold_pct <= 100.0))
    bad("threshold_pct", std::to_string(o.threshold_pct), "expected a percentage in (0, 100]");
  o.reference_mbps = declare<double>(node, "reference_mbps", 0.0);
  o.budget_mbps = declare<std::vector<double>>(node, "budget_mbps", {});
  if (o.reference_mbps <= 0.0 && o.budget_mbps.empty())
    bad("reference_mbps", std::to_string(o.reference_mbps),
        "give the bandwidth threshold_pct is a percentage of (MB/s: what bandwidth_read "
        "reaches alone on the nRT core, the reference.mbps of the host model rosguard calibrate "
        "writes), or budget_mbps");
  o.pmc_source = declare<std::string>(node, "pmc_source", "auto");
  one_of("pmc_source", o.pmc_source, {"auto", "perf", "instrumented", "software"});
  o.keepalive_ms = positive("keepalive_ms", declare<std::int64_t>(node, "keepalive_ms", 20));
  o.rt_isolation_us = declare<std::int64_t>(node, "rt_isolation_us", 0);
  o.events = declare<std::vector<std::string>>(node, "events", o.events);
  return o;
}

}  // namespace rosguard_rclcpp

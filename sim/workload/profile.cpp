#include "workload/profile.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "core/error.h"

namespace rosguard::sim {

double kernel_reuse_kb(double working_set_kb, const SimPlatform& platform) {
  return std::max(0.0, working_set_kb - (platform.l3.exclusive_of_l2 ? platform.l2_kb : 0.0));
}

cache::MissRatioCurve derived_mrc(double kernel_working_set_kb, double footprint_kb, double l3_hit,
                                  const SimPlatform& platform) {
  const double capacity = platform.l3.capacity_kb;
  if (kernel_working_set_kb > 0.0) {
    const double step = kernel_reuse_kb(kernel_working_set_kb, platform);
    return step <= capacity ? cache::MissRatioCurve::step(step, 1.0, 1.0 - l3_hit)
                            : cache::MissRatioCurve::step(step, 1.0 - l3_hit, 0.0);
  }
  return cache::MissRatioCurve::uniform_reuse(footprint_kb, l3_hit, capacity);
}

WorkloadProfile parse_profile(const WorkloadInfo& w, const SimPlatform& platform,
                              const std::string& file, const std::string& base) {
  if (!w.doc.contains("sim"))
    throw InputError(file, base.substr(0, base.rfind('/')),
                     "workload '" + w.name +
                         "' has no \"sim\" profile, so the sim backend "
                         "cannot run it");
  const auto& s = w.doc.at("sim");
  WorkloadProfile p;
  p.name = w.name;
  p.instructions = s.at("instructions").get<double>();
  p.footprint_kb = s.value("footprint_kb", 0.0);
  p.l3_hit = s.value("l3_hit", 1.0);
  p.repeat = s.value("repeat", 1);
  // A built-in cyclic kernel's working set (its derived curve is a step there).
  double kernel_ws = 0.0;
  if (w.doc.contains("hw")) {
    const std::string kernel = w.doc.at("hw").value("kernel", "");
    if (kernel == "bandwidth_read" || kernel == "bandwidth_write" || kernel == "latency")
      kernel_ws = w.doc.at("hw").value("working_set_kb", 2048.0);
  }
  const cache::MissRatioCurve derived = derived_mrc(kernel_ws, p.footprint_kb, p.l3_hit, platform);
  double total = 0.0;
  std::size_t index = 0;
  for (const auto& ph : s.at("phases")) {
    Phase phase;
    phase.fraction = ph.at("fraction").get<double>();
    phase.base_ipc = ph.at("base_ipc").get<double>();
    phase.refill_pki = ph.at("l2_refill_pki").get<double>();
    phase.wb_pki = ph.at("l2_wb_pki").get<double>();
    phase.mlp = ph.value("mlp", 1.0);
    phase.mrc = derived;
    if (ph.contains("mrc")) {
      std::vector<cache::MissRatioCurve::Point> points;
      for (const auto& pt : ph.at("mrc"))
        points.push_back({pt.at("capacity_kb").get<double>(), pt.at("miss_ratio").get<double>()});
      try {
        phase.mrc = cache::MissRatioCurve::from_points(std::move(points));
      } catch (const std::invalid_argument& e) {
        throw InputError(file, base + "/phases/" + std::to_string(index) + "/mrc", e.what());
      }
    }
    ++index;
    total += phase.fraction;
    p.phases.push_back(phase);
  }
  if (std::abs(total - 1.0) > 1e-6) {
    char sum[32];
    std::snprintf(sum, sizeof sum, "%g", total);
    throw InputError(file, base + "/phases",
                     std::string("the phase fractions add up to ") + sum +
                         "; they are shares of the run's instructions and must add up to 1");
  }
  return p;
}

WorkloadProfile kernel_profile(const std::string& name, const std::string& kernel,
                               const KernelModel& model, double working_set_kb, double passes,
                               const SimPlatform& platform) {
  const bool in_l2 = working_set_kb <= platform.l2_kb;
  WorkloadProfile p;
  p.name = name;
  p.instructions = working_set_kb * 1024.0 / kKernelLineBytes * passes;
  p.footprint_kb = working_set_kb;
  p.l3_hit = kernel_reuse_kb(working_set_kb, platform) <= platform.l3.capacity_kb ? 1.0 : 0.0;
  Phase ph;
  const double l2_hit = in_l2 ? 1.0 : kernel == "latency" ? platform.l2_kb / working_set_kb : 0.0;
  ph.base_ipc = 1.0 / ((l2_hit * model.ns_per_line_l2 + (1.0 - l2_hit) * model.ns_per_line_l3) *
                       platform.freq_ghz());
  ph.refill_pki = 1000.0 * (1.0 - l2_hit);
  ph.wb_pki = !in_l2 && kernel == "bandwidth_write" ? 1000.0 : 0.0;
  ph.mlp = model.mlp;
  ph.mrc = derived_mrc(working_set_kb, p.footprint_kb, p.l3_hit, platform);
  p.phases.push_back(ph);
  return p;
}

WorkloadProfile profile_for(const WorkloadInfo& w, const SimPlatform& platform,
                            const std::string& file, const std::string& base) {
  if (!w.is_command() && w.doc.contains("hw")) {
    const auto& hw = w.doc.at("hw");
    const std::string kernel = hw.value("kernel", "");
    if (const auto it = platform.kernels.find(kernel); it != platform.kernels.end())
      return kernel_profile(w.name, kernel, it->second, hw.value("working_set_kb", 2048.0),
                            hw.value("passes", 1.0), platform);
  }
  return parse_profile(w, platform, file, base);
}

void WorkloadRun::retire(double n) {
  n = std::clamp(n, 0.0, remaining_);
  remaining_ -= n;
  retired_in_run_ += n;
}

bool WorkloadRun::next_segment() {
  // Whatever rounding left in the segment counts as retired: the run's total stays exact.
  retired_in_run_ += remaining_;
  remaining_ = 0.0;
  ++segment_;
  if (segment_ >= profile_->segments()) {
    ++runs_completed_;
    retired_in_run_ = 0.0;
    return false;
  }
  remaining_ = profile_->segment_instructions(segment_);
  return true;
}

void WorkloadRun::restart() {
  segment_ = 0;
  retired_in_run_ = 0.0;
  remaining_ = profile_->segment_instructions(0);
}

}  // namespace rosguard::sim

#include "workload/profile.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/error.h"

namespace rosguard::sim {

WorkloadProfile parse_profile(const WorkloadInfo& w, const std::string& file,
                              const std::string& base) {
  if (w.is_command() || !w.doc.contains("sim"))
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
  double total = 0.0;
  for (const auto& ph : s.at("phases")) {
    Phase phase;
    phase.fraction = ph.at("fraction").get<double>();
    phase.base_ipc = ph.at("base_ipc").get<double>();
    phase.refill_pki = ph.at("l2_refill_pki").get<double>();
    phase.wb_pki = ph.at("l2_wb_pki").get<double>();
    phase.mlp = ph.value("mlp", 1.0);
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
  p.l3_hit = working_set_kb <= platform.l3.capacity_kb ? 1.0 : 0.0;
  Phase ph;
  ph.base_ipc = 1.0 / ((in_l2 ? model.ns_per_line_l2 : model.ns_per_line_l3) * platform.freq_ghz());
  ph.refill_pki = in_l2 ? 0.0 : 1000.0;
  ph.wb_pki = !in_l2 && kernel == "bandwidth_write" ? 1000.0 : 0.0;
  ph.mlp = model.mlp;
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
  return parse_profile(w, file, base);
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

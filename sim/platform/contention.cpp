#include "platform/contention.h"

#include <algorithm>
#include <cmath>

namespace rosguard::sim {
namespace {

// Utilisations stay below this: latency(u) is finite, and the fixed point always has a root.
constexpr double kMaxUtil = 0.999;

// Root of an increasing function g on [0, kMaxUtil] (g(0) <= 0), by the Illinois variant of
// regula falsi; kMaxUtil when g stays negative (demand beyond the bandwidth: saturated).
template <class G>
double increasing_root(const G& g) {
  double a = 0.0, fa = g(a);
  if (fa >= 0.0) return 0.0;
  double b = kMaxUtil, fb = g(b);
  if (fb <= 0.0) return kMaxUtil;
  int side = 0;
  for (int i = 0; i < 200; ++i) {
    const double c = (a * fb - b * fa) / (fb - fa);
    const double fc = g(c);
    if (fc == 0.0 || b - a < 1e-13) return c;
    if (fc < 0.0) {
      a = c;
      fa = fc;
      if (side == -1) fb *= 0.5;
      side = -1;
    } else {
      b = c;
      fb = fc;
      if (side == 1) fa *= 0.5;
      side = 1;
    }
  }
  return 0.5 * (a + b);
}

}  // namespace

ContentionModel::ContentionModel(const SimPlatform& platform)
    : p_(platform), f_ghz_(platform.freq_ghz()), line_(platform.line_bytes) {}

double ContentionModel::l3_latency(double u) const {
  u = std::clamp(u, 0.0, kMaxUtil);
  return p_.l3.latency_ns + p_.l3.queue_ns * u / (1.0 - u);
}

double ContentionModel::dram_latency(double u) const {
  u = std::clamp(u, 0.0, kMaxUtil);
  return p_.dram.latency_ns + p_.dram.queue_ns * u / (1.0 - u);
}

MemoryState ContentionModel::unloaded(std::size_t demands) const {
  MemoryState s;
  const auto n = static_cast<std::size_t>(p_.clusters);
  s.l3_ns.assign(n, p_.l3.latency_ns);
  s.l3_util.assign(n, 0.0);
  s.capacity_factor.assign(demands, 1.0);
  s.dram_ns = p_.dram.latency_ns;
  return s;
}

CoreRates ContentionModel::rates(const Phase& ph, double l3_hit, int cluster, double capf,
                                 const MemoryState& st) const {
  const auto k = static_cast<std::size_t>(cluster);
  const double h = l3_hit * capf;
  const double latency = st.l3_ns[k] + (1.0 - h) * st.dram_ns;
  const double stall =
      ph.refill_pki / 1000.0 * f_ghz_ * std::max(0.0, latency - p_.l3.latency_ns) / ph.mlp;
  const double cpi = 1.0 / ph.base_ipc + stall;
  CoreRates r;
  r.inst_per_ns = f_ghz_ / cpi;
  r.refill_per_ns = r.inst_per_ns * ph.refill_pki / 1000.0;
  r.wb_per_ns = r.inst_per_ns * ph.wb_pki / 1000.0;
  r.l3_refill_per_ns = (1.0 - h) * r.refill_per_ns;
  r.dram_lines_per_ns = (1.0 - h) * (r.refill_per_ns + r.wb_per_ns);
  return r;
}

std::vector<double> ContentionModel::shares(std::span<const CoreDemand> demands) const {
  std::vector<double> share(demands.size(), 0.0);
  for (int c = 0; c < p_.clusters; ++c) {
    std::vector<std::size_t> members;
    double footprint = 0.0;
    for (std::size_t i = 0; i < demands.size(); ++i)
      if (demands[i].cluster == c && demands[i].resident && demands[i].footprint_kb > 0) {
        members.push_back(i);
        footprint += demands[i].footprint_kb;
      }
    if (footprint <= p_.l3.capacity_kb) {
      for (std::size_t i : members)
        share[i] = demands[i].footprint_kb;
      continue;
    }
    // Pressure: L3 lines inserted per ns at the unloaded latency (a resident core with no phase
    // known keeps a minimal pressure).
    std::vector<double> pressure(demands.size(), 0.0);
    const MemoryState idle = unloaded(0);
    for (std::size_t i : members) {
      const Phase* ph = demands[i].resident_phase ? demands[i].resident_phase : demands[i].phase;
      if (ph) {
        const CoreRates r = rates(*ph, demands[i].l3_hit, c, 1.0, idle);
        pressure[i] = r.refill_per_ns + r.wb_per_ns;
      }
      pressure[i] = std::max(pressure[i], 1e-9);
    }
    // Water-filling: shares in proportion to pressure, capped at the footprint.
    std::vector<bool> capped(demands.size(), false);
    double left = p_.l3.capacity_kb;
    for (std::size_t round = 0; round < members.size(); ++round) {
      double total = 0.0;
      for (std::size_t i : members)
        if (!capped[i]) total += pressure[i];
      bool any = false;
      for (std::size_t i : members)
        if (!capped[i] && left * pressure[i] / total >= demands[i].footprint_kb) {
          capped[i] = true;
          share[i] = demands[i].footprint_kb;
          any = true;
        }
      if (!any) {
        for (std::size_t i : members)
          if (!capped[i]) share[i] = left * pressure[i] / total;
        break;
      }
      left = p_.l3.capacity_kb;
      for (std::size_t i : members)
        if (capped[i]) left -= share[i];
    }
  }
  return share;
}

std::vector<double> ContentionModel::capacity_factors(std::span<const CoreDemand> demands) const {
  const std::vector<double> share = shares(demands);
  std::vector<double> factor(demands.size(), 1.0);
  for (std::size_t i = 0; i < demands.size(); ++i)
    if (demands[i].resident && demands[i].footprint_kb > 0)
      factor[i] =
          std::pow(std::min(1.0, share[i] / demands[i].footprint_kb), p_.l3.capacity_exponent);
  return factor;
}

double ContentionModel::l3_traffic(std::span<const CoreDemand> demands,
                                   const std::vector<double>& capf, int cluster, double l3_ns,
                                   double dram_ns, double* dram_bytes) const {
  MemoryState st;
  const auto k = static_cast<std::size_t>(cluster);
  st.l3_ns.assign(k + 1, l3_ns);
  st.dram_ns = dram_ns;
  double bytes = 0.0;
  for (std::size_t i = 0; i < demands.size(); ++i) {
    const CoreDemand& d = demands[i];
    if (d.cluster != cluster || d.phase == nullptr) continue;
    const CoreRates r = rates(*d.phase, d.l3_hit, cluster, capf[i], st);
    bytes += (r.refill_per_ns + r.wb_per_ns) * line_;
    if (dram_bytes) *dram_bytes += r.dram_lines_per_ns * line_;
  }
  return bytes;
}

double ContentionModel::alone_inst_per_ns(const Phase& phase, double l3_hit, double footprint_kb,
                                          int cluster) const {
  CoreDemand d;
  d.cluster = cluster;
  d.phase = &phase;
  d.l3_hit = l3_hit;
  d.footprint_kb = footprint_kb;
  d.resident = true;
  d.resident_phase = &phase;
  const MemoryState state = solve(std::span(&d, 1));
  return rates(phase, l3_hit, cluster, state.capacity_factor.at(0), state).inst_per_ns;
}

MemoryState ContentionModel::solve(std::span<const CoreDemand> demands) const {
  const std::vector<double> capf = capacity_factors(demands);
  return solve(demands, capf);
}

MemoryState ContentionModel::solve(std::span<const CoreDemand> demands,
                                   std::span<const double> capf) const {
  MemoryState s = unloaded(demands.size());
  s.capacity_factor.assign(capf.begin(), capf.end());
  std::vector<bool> busy(s.l3_ns.size(), false);
  for (const auto& d : demands)
    if (d.phase) busy[static_cast<std::size_t>(d.cluster)] = true;

  const double l3_bw = bytes_per_ns(p_.l3.bandwidth_mbps);
  const double dram_bw = bytes_per_ns(p_.dram.bandwidth_mbps);
  // Given the DRAM latency: each cluster's L3 utilisation, and the DRAM traffic that results.
  const auto clusters_given = [&](double dram_ns, MemoryState& out) {
    double dram_bytes = 0.0;
    for (std::size_t k = 0; k < out.l3_ns.size(); ++k) {
      if (!busy[k]) continue;
      const int c = static_cast<int>(k);
      const double u = increasing_root([&](double x) {
        return x -
               l3_traffic(demands, s.capacity_factor, c, l3_latency(x), dram_ns, nullptr) / l3_bw;
      });
      out.l3_util[k] = u;
      out.l3_ns[k] = l3_latency(u);
      l3_traffic(demands, s.capacity_factor, c, out.l3_ns[k], dram_ns, &dram_bytes);
    }
    return dram_bytes;
  };
  const double ud = increasing_root([&](double x) {
    MemoryState trial = s;
    return x - clusters_given(dram_latency(x), trial) / dram_bw;
  });
  s.dram_util = ud;
  s.dram_ns = dram_latency(ud);
  clusters_given(s.dram_ns, s);
  return s;
}

}  // namespace rosguard::sim

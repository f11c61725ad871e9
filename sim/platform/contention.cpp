#include "platform/contention.h"

#include <algorithm>
#include <cmath>

namespace rosguard::sim {
namespace {

// Utilisations stay below this: latency(u) is finite, and the fixed point always has a root.
constexpr double kMaxUtil = 0.999;

// A root of an increasing function g, narrowed by the Illinois variant of regula falsi.
struct RootBracket {
  double lo;    // the bracket's low end, g(lo) <= 0: the side where g has not reached its root
  double root;  // the estimate: the secant point of the bracket (g's root where g vanished there)
};

// Narrows [a, b], with g(a) = fa < 0 < fb = g(b), until g vanishes at the secant point or the
// bracket is under 1e-13 wide; after 200 steps without either, the estimate is the midpoint.
template <class G>
RootBracket narrow_root(const G& g, double a, double fa, double b, double fb) {
  int side = 0;
  for (int i = 0; i < 200; ++i) {
    const double c = (a * fb - b * fa) / (fb - fa);
    if (b - a < 1e-13) return {a, c};
    const double fc = g(c);
    if (fc == 0.0) return {c, c};
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
  return {a, 0.5 * (a + b)};
}

// Root of an increasing function g on [0, kMaxUtil] (g(0) <= 0); kMaxUtil when g stays negative
// (demand beyond the bandwidth: saturated).
template <class G>
double increasing_root(const G& g) {
  const double fa = g(0.0);
  if (fa >= 0.0) return 0.0;
  const double fb = g(kMaxUtil);
  if (fb <= 0.0) return kMaxUtil;
  return narrow_root(g, 0.0, fa, kMaxUtil, fb).root;
}

// The occupancies (KB) of tenants sharing an LRU cache of `cap` KB (their natural partition),
// where each tenant's access rate depends on its hit ratio, so on its occupancy:
// rate(j, occupancy) per ns. Iterated from an equal split (a contraction in practice: more
// cache, more hits, a little faster; the relaxation after 20 rounds only guards against a
// cycle).
template <class Rate>
std::vector<double> shared_occupancies(const std::vector<const cache::MissRatioCurve*>& curves,
                                       double cap, double line_kb, const Rate& rate) {
  std::vector<double> occ(curves.size(), cap / static_cast<double>(curves.size()));
  std::vector<cache::Tenant> tenants(curves.size());
  for (int round = 0; round < 100; ++round) {
    for (std::size_t j = 0; j < curves.size(); ++j)
      tenants[j] = {curves[j], rate(j, occ[j])};
    const std::vector<double> next = cache::natural_partition(tenants, cap, line_kb);
    double moved = 0.0;
    const double w = round < 20 ? 1.0 : 0.5;
    for (std::size_t j = 0; j < curves.size(); ++j) {
      moved = std::max(moved, std::abs(next[j] - occ[j]));
      occ[j] = w * next[j] + (1.0 - w) * occ[j];
    }
    if (moved <= 1e-9 * cap) break;
  }
  return occ;
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

double ContentionModel::miss_latency(double g, double dram_ns) const {
  return p_.slc ? g * p_.slc->latency_ns + (1.0 - g) * dram_ns : dram_ns;
}

MemoryState ContentionModel::unloaded(std::size_t demands) const {
  MemoryState s;
  const auto n = static_cast<std::size_t>(p_.clusters);
  s.l3_ns.assign(n, p_.l3.latency_ns);
  s.l3_util.assign(n, 0.0);
  s.mlp_scale.assign(n, 1.0);
  s.l3_hit.assign(demands, 1.0);
  s.slc_hit.assign(demands, 0.0);
  s.dram_ns = p_.dram.latency_ns;
  return s;
}

CoreRates ContentionModel::rates(const Phase& ph, double hit, int cluster, const MemoryState& st,
                                 double slc_hit) const {
  const auto k = static_cast<std::size_t>(cluster);
  return rates_at(ph, hit, st.l3_ns[k], st.dram_ns, k < st.mlp_scale.size() ? st.mlp_scale[k] : 1.0,
                  slc_hit);
}

CoreRates ContentionModel::rates_at(const Phase& ph, double hit, double l3_ns, double dram_ns,
                                    double scale, double slc_hit) const {
  const double h = std::clamp(hit, 0.0, 1.0);
  const double g = std::clamp(slc_hit, 0.0, 1.0);
  const double latency = l3_ns + (1.0 - h) * miss_latency(g, dram_ns);
  const double inflight = std::min(ph.mlp, p_.mshr.per_core) * scale;
  const double stall =
      ph.refill_pki / 1000.0 * f_ghz_ * std::max(0.0, latency - p_.l3.latency_ns) / inflight;
  const double cpi = 1.0 / ph.base_ipc + stall;
  CoreRates r;
  r.inst_per_ns = f_ghz_ / cpi;
  r.refill_per_ns = r.inst_per_ns * ph.refill_pki / 1000.0;
  r.wb_per_ns = r.inst_per_ns * ph.wb_pki / 1000.0;
  r.l3_refill_per_ns = (1.0 - h) * r.refill_per_ns;
  r.dram_wb_per_ns = (1.0 - h) * r.wb_per_ns;
  r.dram_lines_per_ns = (1.0 - h) * (1.0 - g) * r.refill_per_ns + r.dram_wb_per_ns;
  return r;
}

std::vector<double> ContentionModel::occupancies(std::span<const CoreDemand> demands) const {
  std::vector<double> occ(demands.size(), 0.0);
  const MemoryState idle = unloaded(0);
  std::vector<std::size_t> members;
  std::vector<const cache::MissRatioCurve*> curves;
  for (int c = 0; c < p_.clusters; ++c) {
    members.clear();
    curves.clear();
    for (std::size_t i = 0; i < demands.size(); ++i) {
      const CoreDemand& d = demands[i];
      if (d.cluster != c || !d.resident || !(d.resident_phase || d.phase)) continue;
      members.push_back(i);
      curves.push_back(&(d.resident_phase ? d.resident_phase : d.phase)->mrc);
    }
    if (members.empty()) continue;
    const auto rate = [&](std::size_t j, double o) {
      const CoreDemand& d = demands[members[j]];
      const Phase& ph = *(d.resident_phase ? d.resident_phase : d.phase);
      return rates(ph, 1.0 - ph.mrc.miss_ratio(o), c, idle).refill_per_ns;
    };
    const std::vector<double> share =
        shared_occupancies(curves, p_.l3.capacity_kb, line_kb(), rate);
    for (std::size_t j = 0; j < members.size(); ++j)
      occ[members[j]] = share[j];
  }
  return occ;
}

std::vector<double> ContentionModel::steady_hits(std::span<const CoreDemand> demands) const {
  const std::vector<double> occ = occupancies(demands);
  std::vector<double> hits(demands.size(), 1.0);
  for (std::size_t i = 0; i < demands.size(); ++i) {
    const Phase* ph = demands[i].phase ? demands[i].phase : demands[i].resident_phase;
    if (ph) hits[i] = 1.0 - ph->mrc.miss_ratio(occ[i]);
  }
  return hits;
}

std::vector<double> ContentionModel::slc_hits(std::span<const CoreDemand> demands,
                                              std::span<const double> hits) const {
  std::vector<double> g(demands.size(), 0.0);
  if (!p_.slc) return g;
  std::vector<std::size_t> members;
  std::vector<cache::MissRatioCurve> beyond;  // each member's curve past what its L3 share holds
  for (std::size_t i = 0; i < demands.size(); ++i) {
    const Phase* ph = demands[i].phase;
    if (ph == nullptr) continue;
    members.push_back(i);
    beyond.push_back(ph->mrc.beyond(ph->mrc.capacity_for(1.0 - hits[i])));
  }
  if (members.empty()) return g;
  std::vector<const cache::MissRatioCurve*> curves;
  for (const auto& c : beyond)
    curves.push_back(&c);
  const MemoryState idle = unloaded(0);
  // As for the L3 (occupancies()), fed by the L3 misses.
  const auto rate = [&](std::size_t j, double o) {
    const std::size_t i = members[j];
    return rates(*demands[i].phase, hits[i], demands[i].cluster, idle,
                 1.0 - beyond[j].miss_ratio(o))
        .l3_refill_per_ns;
  };
  const std::vector<double> occ = shared_occupancies(curves, p_.slc->capacity_kb, line_kb(), rate);
  for (std::size_t j = 0; j < members.size(); ++j)
    g[members[j]] = 1.0 - beyond[j].miss_ratio(occ[j]);
  return g;
}

double ContentionModel::cluster_scale(std::span<const CoreDemand> demands,
                                      std::span<const double> hits, std::span<const double> slc,
                                      int cluster, double l3_ns, double dram_ns) const {
  // L3 misses in flight (Little's law) at scale s.
  const auto inflight = [&](double s) {
    double sum = 0.0;
    for (std::size_t i = 0; i < demands.size(); ++i) {
      const CoreDemand& d = demands[i];
      if (d.cluster != cluster || d.phase == nullptr) continue;
      sum += rates_at(*d.phase, hits[i], l3_ns, dram_ns, s, slc[i]).l3_refill_per_ns *
             miss_latency(slc[i], dram_ns);
    }
    return sum;
  };
  const double bound = p_.mshr.per_cluster;
  const double unscaled = inflight(1.0);
  if (unscaled <= bound) return 1.0;
  // Increasing in s, 0 at s = 0: the root of inflight(s) = bound in (0, 1), taken on the side
  // where the bound holds.
  const auto excess = [&](double s) { return inflight(s) - bound; };
  return narrow_root(excess, 0.0, -bound, 1.0, unscaled - bound).lo;
}

double ContentionModel::l3_traffic(std::span<const CoreDemand> demands,
                                   std::span<const double> hits, std::span<const double> slc,
                                   int cluster, double l3_ns, double dram_ns, double* dram_bytes,
                                   double* scale) const {
  const double s = cluster_scale(demands, hits, slc, cluster, l3_ns, dram_ns);
  if (scale) *scale = s;
  double bytes = 0.0;
  for (std::size_t i = 0; i < demands.size(); ++i) {
    const CoreDemand& d = demands[i];
    if (d.cluster != cluster || d.phase == nullptr) continue;
    const CoreRates r = rates_at(*d.phase, hits[i], l3_ns, dram_ns, s, slc[i]);
    bytes += (r.refill_per_ns + r.wb_per_ns) * line_;
    if (dram_bytes)
      *dram_bytes +=
          (r.dram_lines_per_ns - (1.0 - p_.dram.writeback_weight) * r.dram_wb_per_ns) * line_;
  }
  return bytes;
}

double ContentionModel::alone_inst_per_ns(const Phase& phase, int cluster) const {
  CoreDemand d;
  d.cluster = cluster;
  d.phase = &phase;
  d.workload = &phase;
  d.resident = true;
  d.resident_phase = &phase;
  const MemoryState state = solve(std::span(&d, 1));
  return rates(phase, state.l3_hit.at(0), cluster, state, state.slc_hit.at(0)).inst_per_ns;
}

MemoryState ContentionModel::solve(std::span<const CoreDemand> demands) const {
  const std::vector<double> hits = steady_hits(demands);
  return solve(demands, hits);
}

MemoryState ContentionModel::solve(std::span<const CoreDemand> demands,
                                   std::span<const double> hits) const {
  MemoryState s = unloaded(demands.size());
  s.l3_hit.assign(hits.begin(), hits.end());
  s.slc_hit = slc_hits(demands, hits);
  const std::span<const double> slc = s.slc_hit;
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
               l3_traffic(demands, hits, slc, c, l3_latency(x), dram_ns, nullptr, nullptr) / l3_bw;
      });
      out.l3_util[k] = u;
      out.l3_ns[k] = l3_latency(u);
      l3_traffic(demands, hits, slc, c, out.l3_ns[k], dram_ns, &dram_bytes, &out.mlp_scale[k]);
    }
    return dram_bytes;
  };
  MemoryState trial = s;  // assigned from s at each step: its vectors keep their storage
  const double ud = increasing_root([&](double x) {
    trial = s;
    return x - clusters_given(dram_latency(x), trial) / dram_bw;
  });
  s.dram_util = ud;
  s.dram_ns = dram_latency(ud);
  clusters_given(s.dram_ns, s);
  return s;
}

}  // namespace rosguard::sim

#include "calibration/isolation.h"

#include <cmath>

#include "metric/metric.h"
#include "platform/contention.h"

namespace rosguard::sim {

IsolationFigures isolation_steady_state(const SimPlatform& p, const WorkloadProfile& w) {
  const ContentionModel model(p);
  double cycles = 0.0, l3 = 0.0, ns = 0.0;
  for (const Phase& ph : w.phases) {
    CoreDemand d{0, &ph, &w, true, &ph};
    const MemoryState st = model.solve({&d, 1});
    const CoreRates r = model.rates(ph, st.l3_hit[0], 0, st, st.slc_hit[0]);
    const double inst = w.instructions * ph.fraction;
    const double t = inst / r.inst_per_ns;
    ns += t;
    cycles += t * p.freq_ghz();
    l3 += t * (r.refill_per_ns + r.wb_per_ns);
  }
  return {w.instructions / cycles, eq1_mbps(p.line_bytes, p.freq_mhz * 1e6, l3, cycles), ns / 1e6};
}

IsolationFigures fit_isolation(const SimPlatform& p, WorkloadProfile& w, double ipc, double mbps) {
  for (int it = 0; it < 200; ++it) {
    const IsolationFigures fig = isolation_steady_state(p, w);
    const double a = fig.mbps > 0 && mbps > 0 ? mbps / fig.mbps : 1.0;
    const double b = ipc / fig.ipc;
    for (Phase& ph : w.phases) {
      ph.refill_pki *= std::pow(a, 0.7);
      ph.wb_pki *= std::pow(a, 0.7);
      ph.base_ipc *= std::pow(b, 0.7);
    }
  }
  return isolation_steady_state(p, w);
}

}  // namespace rosguard::sim

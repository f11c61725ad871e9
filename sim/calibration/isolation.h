// A workload profile alone on one core of a platform, from the memory model's steady state
// (each phase at its own fixed point, aggregated), and the fit of its base IPC to a measured
// IPC. Used by `rosguard profile --fit-ipc / --measure-ipc` and rosguard-sim-calibrate.
//
// Contract: pure C++ (no SystemC). The steady state ignores the quantum (a phase's first quantum
// runs at the latencies of the one before); the calibration test (tests/sim) checks the
// simulated figures within 3 %.
#pragma once

#include "platform/sim_platform.h"
#include "workload/profile.h"

namespace rosguard::sim {

struct IsolationFigures {
  double ipc = 0.0;
  double mbps = 0.0;  // Eq. 1: L2 refills + write-backs x line size per second
  double time_ms = 0.0;
};

IsolationFigures isolation_steady_state(const SimPlatform& platform, const WorkloadProfile& w);

// Scales every phase's base_ipc (and, when `mbps` > 0, every phase's L2 refill and write-back
// rates) until the isolation IPC equals `ipc` (and the Eq. 1 bandwidth `mbps`): a fixed-point
// iteration on the two factors, the rates being monotone in each. The phases' relative shape,
// mlp, l3_hit and footprint stay as written. Returns the figures after the fit.
IsolationFigures fit_isolation(const SimPlatform& platform, WorkloadProfile& w, double ipc,
                               double mbps = 0.0);

}  // namespace rosguard::sim

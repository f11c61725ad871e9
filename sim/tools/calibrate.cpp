// rosguard-sim-calibrate: isolation figures of workload profiles from the memory model's steady
// state, and fitting of profiles to their reference (the paper's Table 1).
//
//   rosguard-sim-calibrate PLATFORM.json WORKLOAD.json...          report IPC and MB/s vs reference
//   rosguard-sim-calibrate --fit [--ipc-only] [--write] PLATFORM.json WORKLOAD.json...
//
// --fit scales every phase's L2 miss rates (refill and write-back together) and every phase's
// base IPC by two factors until the isolation IPC and Eq. 1 bandwidth equal the workload's
// "reference"; the phases' relative shape, mlp, l3_hit and footprint stay as written. With
// --ipc-only only the base IPC is scaled (to the reference IPC): the miss rates stay as written
// and the bandwidth follows from them. --write stores the fitted numbers (4 significant digits)
// back into the workload files. tools/fit_table1.py drives it for the seven Table 1 workloads.
//
// The steady state and the fit: sim/calibration/isolation.h (as `rosguard profile --fit-ipc`).
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "calibration/isolation.h"
#include "core/error.h"
#include "metric/metric.h"
#include "platform/contention.h"
#include "platform/sim_platform.h"
#include "workload/profile.h"

namespace {

using namespace rosguard;
using namespace rosguard::sim;
using ojson = nlohmann::ordered_json;

double round4(double v) {
  if (v == 0.0) return 0.0;
  const double mag = std::pow(10.0, std::floor(std::log10(std::abs(v))) - 3);
  return std::round(v / mag) * mag;
}

ojson read(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw RunError("cannot read " + path);
  return ojson::parse(in);
}

}  // namespace

int main(int argc, char** argv) {
  bool fit = false, write = false, ipc_only = false;
  std::vector<std::string> files;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--fit")
      fit = true;
    else if (a == "--write")
      write = true;
    else if (a == "--ipc-only")
      ipc_only = true;
    else
      files.push_back(a);
  }
  if (files.size() < 2) {
    std::cerr << "usage: rosguard-sim-calibrate [--fit [--ipc-only] [--write]] PLATFORM.json "
                 "WORKLOAD.json...\n";
    return 2;
  }
  try {
    const ojson pdoc = read(files[0]);
    const SimPlatform plat =
        parse_sim_platform(build_platform(nlohmann::json::parse(pdoc.dump()), files[0]));
    std::printf("%-16s %8s %8s %7s %10s %10s %7s %9s\n", "workload", "ipc", "ref", "err%", "MB/s",
                "ref", "err%", "time_ms");
    for (std::size_t f = 1; f < files.size(); ++f) {
      ojson doc = read(files[f]);
      const double ref_ipc = doc["reference"].value("ipc", 0.0);
      const double ref_mbps = doc["reference"].value("mbps", 0.0);
      WorkloadInfo info{doc.value("name", ""), files[f], nlohmann::json::parse(doc.dump())};
      WorkloadProfile w = parse_profile(info, plat, files[f], "/sim");
      if (fit && ref_ipc > 0) {
        fit_isolation(plat, w, ref_ipc, ipc_only ? 0.0 : ref_mbps);
        auto& phases = doc["sim"]["phases"];
        for (std::size_t i = 0; i < w.phases.size(); ++i) {
          w.phases[i].base_ipc = round4(w.phases[i].base_ipc);
          w.phases[i].refill_pki = round4(w.phases[i].refill_pki);
          w.phases[i].wb_pki = round4(w.phases[i].wb_pki);
          phases[i]["base_ipc"] = w.phases[i].base_ipc;
          phases[i]["l2_refill_pki"] = w.phases[i].refill_pki;
          phases[i]["l2_wb_pki"] = w.phases[i].wb_pki;
        }
        if (write) {
          std::ofstream out(files[f]);
          out << doc.dump(2) << "\n";
        }
      }
      const IsolationFigures fig = isolation_steady_state(plat, w);
      std::printf("%-16s %8.4f %8.4f %+7.3f %10.2f %10.2f %+7.3f %9.2f\n", w.name.c_str(), fig.ipc,
                  ref_ipc, ref_ipc > 0 ? 100.0 * (fig.ipc / ref_ipc - 1) : 0.0, fig.mbps, ref_mbps,
                  ref_mbps > 0 ? 100.0 * (fig.mbps / ref_mbps - 1) : 0.0, fig.time_ms);
    }
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

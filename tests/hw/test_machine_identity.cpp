// The machine a host model records (hw::host_facts of the calibration suite's probe) and the
// machine a "platform": "host" run reads without the hw backend (tools/rosguard/load/host_facts.h
// this_machine()) are read by separate code: on one machine they must be the same identity, or
// every model calibrated here would warn that it was measured elsewhere.
#include <catch2/catch.hpp>

#include "calibration/measurements.h"
#include "hw/host_probe.h"
#include "load/host_facts.h"

using namespace rosguard;

TEST_CASE("the probe's machine identity is the one a host run reads", "[hw][host]") {
  const hw::HostProbe probe = hw::probe_host({.measure_reference = false});
  const calibration::MachineIdentity recorded =
      calibration::machine_identity(hw::host_facts(probe));
  const calibration::MachineIdentity current = this_machine();
  INFO("probe:        " << calibration::describe(recorded));
  INFO("this_machine: " << calibration::describe(current));
  CHECK(calibration::identity_differences(recorded, current).empty());
  CHECK_FALSE(recorded.kernel.empty());
}

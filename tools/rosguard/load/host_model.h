// "platform": "host": where the calibrated model of this host lives, and the host platform each
// backend uses (docs/design.md, section 4).
//
// - hw backend: the machine probed at load time (hw/host_probe.h), with the reference, memory
//   model and costs of the installed model when there is one.
// - sim backend: the installed model (written by `rosguard calibrate --install`).
//
// Contract: called from the main thread (the loader, `rosguard platform probe`); errors are
// InputError naming the file and JSON path (exit 2) or RunError (exit 1).
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "calibration/measurements.h"
#include "load/schema.h"

namespace rosguard {

// The reserved platform name.
inline constexpr const char* kHostPlatform = "host";

// Where the calibrated model of this host is (or will be installed): $ROSGUARD_HOST_MODEL when
// set and not empty, else ${XDG_DATA_HOME:-$HOME/.local/share}/rosguard/host/platform.json.
// Throws RunError when neither ROSGUARD_HOST_MODEL, XDG_DATA_HOME nor HOME is set.
std::filesystem::path host_model_path();

// Whether a host model was measured on the current machine: its "measured_on" (written by
// `rosguard calibrate` since it records it) compared with `current`.
struct ModelMachineCheck {
  bool known = false;    // the model records its machine
  bool matches = false;  // ... and it is `current` (calibration::identity_differences is empty)
  std::vector<std::string> differences;  // what differs (empty when it matches or is unknown)
  std::string warning;                   // for the user and the manifest; empty when it matches
  nlohmann::json record;  // the manifest's: measured_on (null: unknown), this_machine, differences
};

// Pure: the check of the model document `doc` (shown as `origin` in the warning) against the
// machine `current`. A model without "measured_on" (calibrated before rosguard recorded it)
// warns that its machine is unknown.
ModelMachineCheck check_model_machine(const nlohmann::json& doc, const std::string& origin,
                                      const calibration::MachineIdentity& current);

// A host platform document and how it was made.
struct HostPlatform {
  nlohmann::json doc;     // validated against the platform schema
  std::string origin;     // for PlatformInfo::origin and messages
  nlohmann::json record;  // for the manifest: backend, where the model came from, the probe
  // The installed model's machine against this one (this_machine()); unset when no model is
  // used (hw without an installed model).
  std::optional<ModelMachineCheck> machine;
};

// The installed model, validated (an invalid one is an InputError naming its file), with its
// machine checked against this one (HostPlatform::machine, also in the record as "machine"), or
// nullopt when there is no file at host_model_path().
std::optional<HostPlatform> installed_host_model(const SchemaSet& schemas);

// The probed host (hw backend). Throws RunError in a build without the hw backend.
HostPlatform probed_host_platform(const SchemaSet& schemas);

// `rosguard platform model`: whether the installed host model was measured on this machine.
// Prints the model's machine, this one and what differs; returns 0 when it matches, 3 when no
// model is installed or it does not match or does not say (tools/validate.sh recalibrates then).
inline constexpr int kNoModelOfThisMachine = 3;
int platform_model_command(const SchemaSet& schemas);

// `rosguard platform contention [--out F]`: one contention probe now (hw::measure_contention),
// on the cores and working set of the installed model's recorded state when it has one (else
// the first two usable CPUs and the quick suite's DRAM set), printed beside that state. `out`
// gets the probe as JSON with "model" (the recorded state, or null) and "matches" (or null).
// Returns 0 when the machine is in the model's state, kNoModelOfThisMachine when it is not, or
// no model or no recorded state is installed. Throws RunError in a build without the hw backend.
int platform_contention_command(const SchemaSet& schemas, const std::string& out);

// `rosguard platform probe [--out F]`: prints the probed platform, or writes it to `out`
// atomically; notes go to stderr. A missing or unwritable folder for `out` is an InputError.
int platform_probe_command(const SchemaSet& schemas, const std::string& out);

}  // namespace rosguard

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

#include "schema.h"

namespace rosguard {

// The reserved platform name.
inline constexpr const char* kHostPlatform = "host";

// Where the calibrated model of this host is (or will be installed): $ROSGUARD_HOST_MODEL when
// set and not empty, else ${XDG_DATA_HOME:-$HOME/.local/share}/rosguard/host/platform.json.
// Throws RunError when neither ROSGUARD_HOST_MODEL, XDG_DATA_HOME nor HOME is set.
std::filesystem::path host_model_path();

// A host platform document and how it was made.
struct HostPlatform {
  nlohmann::json doc;     // validated against the platform schema
  std::string origin;     // for PlatformInfo::origin and messages
  nlohmann::json record;  // for the manifest: backend, where the model came from, the probe
};

// The installed model, validated (an invalid one is an InputError naming its file), or nullopt
// when there is no file at host_model_path().
std::optional<HostPlatform> installed_host_model(const SchemaSet& schemas);

// The probed host (hw backend). Throws RunError in a build without the hw backend.
HostPlatform probed_host_platform(const SchemaSet& schemas);

// `rosguard platform probe [--out F]`: prints the probed platform, or writes it to `out`
// atomically; notes go to stderr. A missing or unwritable folder for `out` is an InputError.
int platform_probe_command(const SchemaSet& schemas, const std::string& out);

}  // namespace rosguard

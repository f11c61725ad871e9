#include "load/host_model.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>

#include "core/error.h"
#include "load/files.h"
#include "load/host_facts.h"
#include "load/loader.h"

#ifdef ROSGUARD_WITH_HW
#include "hw/calibration/suite.h"
#include "hw/host_probe.h"
#endif

namespace rosguard {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

std::string env(const char* name) {
  const char* v = std::getenv(name);
  return v ? v : "";
}

std::string join(const std::vector<std::string>& parts, const std::string& sep) {
  std::string s;
  for (const auto& p : parts)
    s += (s.empty() ? "" : sep) + p;
  return s;
}

}  // namespace

ModelMachineCheck check_model_machine(const json& doc, const std::string& origin,
                                      const calibration::MachineIdentity& current) {
  ModelMachineCheck c;
  c.record = json{{"measured_on", nullptr},
                  {"this_machine", calibration::identity_to_json(current)},
                  {"differences", json::array()}};
  const std::string fix = "`rosguard calibrate --install` measures this machine and replaces it";
  if (!doc.is_object() || !doc.contains("measured_on")) {
    c.warning = "the host model " + origin +
                " does not record the machine it was measured on (calibrated before rosguard "
                "wrote \"measured_on\"): whether it describes this machine (" +
                calibration::describe(current) + ") is unknown; " + fix;
    c.record["matches"] = nullptr;  // unknown
    return c;
  }
  const calibration::MachineIdentity model =
      calibration::identity_from_json(doc.at("measured_on"), origin, "/measured_on");
  c.known = true;
  c.record["measured_on"] = doc.at("measured_on");
  c.differences = calibration::identity_differences(model, current);
  c.matches = c.differences.empty();
  c.record["differences"] = c.differences;
  c.record["matches"] = c.matches;
  if (!c.matches) {
    std::string where = model.hostname;
    if (!model.date.empty()) where += (where.empty() ? "" : ", ") + model.date;
    c.warning = "the host model " + origin + " was measured on another machine" +
                (where.empty() ? "" : " (" + where + ")") + ": " + join(c.differences, "; ") +
                "; its numbers describe that machine, not this one; " + fix;
  }
  return c;
}

fs::path host_model_path() {
  if (const auto explicit_path = env("ROSGUARD_HOST_MODEL"); !explicit_path.empty())
    return explicit_path;
  fs::path data = env("XDG_DATA_HOME");
  if (data.empty() || data.is_relative()) {  // the XDG spec ignores a relative XDG_DATA_HOME
    const auto home = env("HOME");
    if (home.empty())
      throw RunError(
          "cannot locate the host model: HOME is not set (set ROSGUARD_HOST_MODEL to its file)");
    data = fs::path(home) / ".local" / "share";
  }
  return data / "rosguard" / "host" / "platform.json";
}

std::optional<HostPlatform> installed_host_model(const SchemaSet& schemas) {
  const fs::path path = host_model_path();
  std::error_code ec;
  if (!fs::exists(path, ec)) return std::nullopt;
  const std::string shown = display_path(path);
  json doc = read_json_file(path, shown);
  schemas.validate(doc, SchemaKind::Platform, shown);
  schemas.apply_defaults(doc, SchemaKind::Platform);
  ModelMachineCheck machine = check_model_machine(doc, shown, this_machine());
  json record{{"backend", "sim"},
              {"model", path.string()},
              {"how",
               "the installed calibrated model of this host "
               "(rosguard calibrate --install; ROSGUARD_HOST_MODEL overrides "
               "where it is looked for)"},
              {"machine", machine.record}};
  return HostPlatform{doc, shown, record, std::move(machine)};
}

HostPlatform probed_host_platform(const SchemaSet& schemas) {
#ifdef ROSGUARD_WITH_HW
  const auto installed = installed_host_model(schemas);
  const hw::HostProbe probe = hw::probe_host({.measure_reference = !installed});
  std::optional<hw::InstalledModel> model;
  if (installed) model = hw::InstalledModel{installed->doc, installed->origin};
  json doc = hw::host_platform_document(probe, model);
  const std::string shown = "host platform probed on " + probe.hostname;
  // The probe builds the document; a schema failure here is rosguard's bug, not the user's.
  if (auto err = schemas.first_error(doc, SchemaKind::Platform))
    throw ContractError("the probed host platform does not validate at " + err->first + ": " +
                        err->second);
  schemas.apply_defaults(doc, SchemaKind::Platform);
  json record{{"backend", "hw"},
              {"how", installed ? "probed at load time; reference, memory and costs from the "
                                  "installed model"
                                : "probed at load time; reference bandwidth measured by the "
                                  "probe (no installed model)"},
              {"probe", hw::to_json(probe)}};
  std::optional<ModelMachineCheck> machine;
  if (installed) {
    record["model"] = installed->record.at("model");
    record["machine"] = installed->record.at("machine");
    machine = installed->machine;
  }
  return {doc, shown + " at " + probe.date, record, machine};
#else
  (void)schemas;
  throw RunError(
      "this rosguard is built without the hw backend (ROSGUARD_WITH_HW=OFF): it cannot probe the "
      "host");
#endif
}

int platform_model_command(const SchemaSet& schemas) {
  const auto installed = installed_host_model(schemas);
  const calibration::MachineIdentity current = this_machine();
  std::cout << "this machine: " << calibration::describe(current) << "\n";
  if (!installed) {
    std::cout << "no host model installed (looked for " << host_model_path().string()
              << "): rosguard calibrate --install makes one\n";
    return kNoModelOfThisMachine;
  }
  const ModelMachineCheck& c = *installed->machine;
  if (c.known) {
    const auto model = calibration::identity_from_json(installed->doc.at("measured_on"),
                                                       installed->origin, "/measured_on");
    std::cout << "host model:   " << installed->origin << ", measured on "
              << calibration::describe(model)
              << (model.hostname.empty() ? "" : " (" + model.hostname + ")")
              << (model.date.empty() ? "" : " at " + model.date) << "\n";
  } else {
    std::cout << "host model:   " << installed->origin << "\n";
  }
  if (c.matches) {
    std::cout << "the host model was measured on this machine\n";
    return 0;
  }
  std::cout << c.warning << "\n";
  return kNoModelOfThisMachine;
}

namespace {

// Refuses a bad --out destination before the measurement's time is spent.
void check_out_file(const std::string& out) {
  if (out.empty()) return;
  const fs::path dest(out);
  const fs::path dir = dest.parent_path().empty() ? fs::path(".") : dest.parent_path();
  std::error_code ec;
  if (fs::is_directory(dest, ec))
    throw InputError(out, "", "--out names a folder; give the path of the JSON file to write");
  if (!fs::is_directory(dir, ec))
    throw InputError(out, "", "cannot write here: the folder " + dir.string() + " does not exist");
  if (::access(dir.c_str(), W_OK) != 0)
    throw InputError(out, "",
                     "cannot write here: the folder " + dir.string() + " is not writable (" +
                         std::strerror(errno) + ")");
}

}  // namespace

int platform_contention_command(const SchemaSet& schemas, const std::string& out) {
#ifdef ROSGUARD_WITH_HW
  check_out_file(out);
  const auto installed = installed_host_model(schemas);
  std::optional<calibration::ContentionProbe> model;
  if (installed && installed->doc.contains("measured_on"))
    model = calibration::identity_from_json(installed->doc.at("measured_on"), installed->origin,
                                            "/measured_on")
                .dram_contention;
  hw::ContentionOptions options;
  options.host = hw::host_facts(hw::probe_host({.measure_reference = false}));
  if (model) {
    options.cores = model->cores;
    options.working_set_kb = model->working_set_kb;
  }
  const hw::ContentionResult now = hw::measure_contention(options);
  for (const auto& note : now.notes)
    std::cerr << "note: " << note << "\n";
  std::cout << "DRAM interference now: " << calibration::describe(now.probe) << "\n";
  // The other way round, on the same working set, then the first way again: a VM's vCPUs need
  // not share the memory path alike (1.78x one way, 1.36x the other on the development VM,
  // 2026-11-28), and the model has one DRAM queue for every core. The state flips within seconds
  // there too, so the two ways are compared only when the first way found the same state after
  // the reverse as before it. Said and recorded; the state is the first probe's.
  const auto probe = [&](std::vector<int> cores) {
    hw::ContentionOptions o = options;
    o.cores = std::move(cores);
    o.working_set_kb = now.probe.working_set_kb;
    return hw::measure_contention(o).probe;
  };
  const auto reverse = probe({now.probe.cores.at(1), now.probe.cores.at(0)});
  const auto again = probe(now.probe.cores);
  const bool held = calibration::same_contention_state(now.probe, again);
  const bool alike = calibration::same_contention_state(now.probe, reverse);
  std::cout << "the other way round:   " << calibration::describe(reverse) << "\n"
            << "the first way again:   " << calibration::describe(again) << "\n";
  if (!held)
    std::cout << "the state changed while probing: the two ways are not compared\n";
  else if (!alike)
    std::cout << "the two CPUs are not slowed alike now: the model has one DRAM queue for every "
                 "core, so it predicts co-runs that share the DRAM alike on both\n";
  json doc = calibration::probe_to_json(now.probe);
  doc["reverse"] = calibration::probe_to_json(reverse);
  doc["again"] = calibration::probe_to_json(again);
  // Whether the two ways were measured in one state (the first way's probes before and after the
  // reverse agree) and, when so, slowed alike; null when not comparable.
  doc["alike"] = held ? json(alike) : json(nullptr);
  doc["model"] = nullptr;
  doc["matches"] = nullptr;
  int rc = kNoModelOfThisMachine;
  if (!installed) {
    std::cout << "no host model installed (looked for " << host_model_path().string()
              << "): rosguard calibrate --install makes one\n";
  } else if (!model) {
    std::cout << "the host model " << installed->origin
              << " does not record the DRAM-interference state it was calibrated in (calibrated "
                 "before rosguard recorded it): rosguard calibrate --install records it\n";
  } else {
    const bool same = calibration::same_contention_state(*model, now.probe);
    const auto offset = calibration::speed_offset_pct(*model, now.probe);
    doc["model"] = calibration::probe_to_json(*model);
    doc["matches"] = same;
    doc["speed_offset_pct"] = offset ? json(*offset) : json(nullptr);
    std::cout << "host model:            " << calibration::describe(*model) << ", calibrated at "
              << model->date << "\n";
    if (offset) {
      char buf[32];
      std::snprintf(buf, sizeof buf, "%+.1f %%", *offset);
      std::cout << "the reader alone now:  " << buf
                << " against the host model's (the host's speed: the model's isolation times, "
                   "and its regulated nRT slowdowns, are off by about as much now)\n";
    }
    if (same) {
      std::cout << "the same state as the host model's\n";
      rc = 0;
    } else {
      std::cout << "a different state from the host model's (the host places this machine's CPUs "
                   "differently now?): its predictions of co-runs that share the DRAM describe "
                   "the other state; make validate waits for the model's state before each hw "
                   "run, rosguard calibrate --install measures this one\n";
    }
  }
  if (!out.empty()) {
    write_file_atomic(out, doc.dump(2) + "\n");
    std::cerr << "wrote " << out << "\n";
  }
  return rc;
#else
  (void)schemas;
  (void)out;
  throw RunError(
      "this rosguard is built without the hw backend (ROSGUARD_WITH_HW=OFF): it cannot measure "
      "the host");
#endif
}

int platform_probe_command(const SchemaSet& schemas, const std::string& out) {
  check_out_file(out);
  const HostPlatform host = probed_host_platform(schemas);
  for (const auto& note : host.record.at("probe").at("notes"))
    std::cerr << "note: " << note.get<std::string>() << "\n";
  // Its own output must be a valid platform file: checked again as a file would be read.
  // The platform files' key order (nlohmann::json sorts keys).
  nlohmann::ordered_json ordered;
  for (const char* key :
       {"name", "description", "cpu", "caches", "pmu", "reference", "memory", "costs"})
    if (host.doc.contains(key)) ordered[key] = host.doc.at(key);
  for (const auto& [key, value] : host.doc.items())
    if (!ordered.contains(key)) ordered[key] = value;
  const std::string text = ordered.dump(2) + "\n";
  schemas.validate(parse_json_text(text, "platform probe output"), SchemaKind::Platform,
                   "platform probe output");
  if (out.empty()) {
    std::cout << text;
  } else {
    write_file_atomic(out, text);
    std::cerr << "wrote " << out << "\n";
  }
  return 0;
}

}  // namespace rosguard

// `rosguard platform probe | model | contention`: this machine as a platform, whether the
// installed host model was measured on it, and whether it is in the model's DRAM-interference
// state now (load/host_model.h).
#include "commands/command.h"
#include "load/host_model.h"
#include "load/schema.h"

namespace rosguard {

CommandHandler setup_platform(CLI::App& sub) {
  auto out = std::make_shared<std::string>();
  sub.require_subcommand(1);
  auto* probe = sub.add_subcommand(
      "probe",
      "Probe this machine (usable CPUs, clusters sharing a last-level cache, caches, frequency, "
      "the PMU events that open, SCHED_FIFO) and print it as a platform JSON: what \"platform\": "
      "\"host\" uses on the hw backend.");
  probe->add_option("--out", *out, "Write the platform JSON to this file (atomically)");
  probe->footer(
      "Reference, memory model and costs come from the installed host model (rosguard calibrate "
      "--install) when there is one; otherwise the reference bandwidth is measured now "
      "(bandwidth_read, under a second) and there is no memory model, so the sim backend "
      "cannot run the result. Notes on what is missing or not usable go to stderr.");
  auto* model_cmd = sub.add_subcommand(
      "model",
      "Say whether the installed host model (rosguard calibrate --install) was measured on this "
      "machine: its CPU model, usable CPUs, caches and kernel against this machine's.");
  model_cmd->footer(
      "Exit status 0 when it was; 3 when no model is installed, the model was measured on another "
      "machine (what differs is printed), or it does not record its machine (calibrated before "
      "rosguard wrote \"measured_on\"). make validate recalibrates then.");
  auto* contention = sub.add_subcommand(
      "contention",
      "Measure the DRAM interference between two CPUs now (a DRAM-bound bandwidth_read alone and "
      "beside one on the other CPU, 7 rounds, about a second; then the other way round) and say "
      "whether it is the state the installed host model was calibrated in, and how fast the host "
      "runs that reader alone against the model.");
  contention->add_option("--out", *out,
                         "Also write the probe (\"reverse\": the other way round), the model's "
                         "state and whether they match, as JSON, to this file (atomically)");
  contention->footer(
      "Under a hypervisor the host may move this machine's CPUs between places that share the "
      "memory path and places that do not, over minutes: the same machine then shows two or more "
      "states, and a model calibrated in one describes that one; its CPUs need not be slowed "
      "alike either (said when they are not). The state is the first direction's, on the CPUs "
      "the model was calibrated on. The host's speed moves too, faster than the state: the model's "
      "isolation times are off by about as much as the reader alone is (printed; not part of the "
      "state). Exit status 0 in the model's "
      "state; 3 in another, or when no model or no recorded state is installed. make validate "
      "uses it before and after each hw run.");
  return [out, probe, contention](const CommandContext& c) {
    const SchemaSet schemas(c.loader.home().schemas());
    if (*probe) return platform_probe_command(schemas, *out);
    if (*contention) return platform_contention_command(schemas, *out);
    return platform_model_command(schemas);
  };
}

}  // namespace rosguard

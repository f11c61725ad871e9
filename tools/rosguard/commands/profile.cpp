// `rosguard profile --out W.json -- PROGRAM`: a sim workload from a program's memory trace
// (host/profile.h).
#include "host/profile.h"

#include "commands/command.h"
#include "load/schema.h"

namespace rosguard {

CommandHandler setup_profile(CLI::App& sub) {
  auto options = std::make_shared<ProfileOptions>();
  sub.add_option("--out", options->out, "Workload JSON to write (atomically)")->required();
  sub.add_option("--slice-instructions", options->slice_instructions,
                 "Instructions per slice (default 2000000: about 1 ms at 2 GHz and IPC "
                 "1); adjacent similar slices are merged into phases")
      ->check(CLI::PositiveNumber);
  sub.add_option("--max-instructions", options->max_instructions,
                 "Stop after this many instructions (default: the whole run)")
      ->check(CLI::PositiveNumber);
  sub.add_option("--skip-instructions", options->skip_instructions,
                 "Run this many instructions through the caches first, uncounted (e.g. "
                 "a program's start-up); --max-instructions counts from there")
      ->check(CLI::PositiveNumber);
  auto* caches = sub.add_option("--caches", options->caches_kb,
                                "L1,L2,L3 capacities in KB of the target (default 64,256,2048)");
  sub.add_option("--ways", options->ways,
                 "L1,L2,L3 associativity (default 4,8,16: Cortex-A78AE L1D and L2, "
                 "DSU-AE L3)");
  sub.add_option("--name", options->name, "Workload name (default: the program's file name)");
  sub.add_option("--slices-csv", options->slices_csv,
                 "Also write each slice's counts (CSV: first instruction, loads, stores, "
                 "refills, write-backs, L3 misses per MRC capacity) to this file");
  sub.add_option("--tracer", options->tracer,
                 "lackey (default: a memory trace through the cache model; measures mlp; about "
                 "2 M instructions per second) or callgrind (valgrind's own cache model, one run "
                 "per MRC capacity, --jobs at a time; about 40 M per second and run; no mlp)")
      ->check(CLI::IsMember({"lackey", "callgrind"}));
  sub.add_option("--jobs", options->jobs, "callgrind runs at a time (default: one per CPU)")
      ->check(CLI::PositiveNumber);
  auto* platform = sub.add_option(
      "--platform", options->platform,
      "The target: its caches (unless --caches says otherwise) and the platform base_ipc is "
      "fitted on: host (this machine's calibrated model), a platform file, or a name (rosguard "
      "list platforms; default orin-agx)");
  sub.add_option("--fit-ipc", options->fit_ipc,
                 "Fit base_ipc so the sim's isolation IPC on --platform equals this measured "
                 "IPC (e.g. perf stat instructions / cycles of the program on the target)")
      ->check(CLI::PositiveNumber);
  sub.add_flag("--measure-ipc", options->measure_ipc,
               "Fit base_ipc to the IPC of the program run natively here (--repeat runs, median "
               "CPU time, at --platform's frequency): for --platform host");
  sub.add_option("--repeat", options->repeat, "Native runs for --measure-ipc (default 3)")
      ->check(CLI::Range(1, 100));
  sub.add_flag("--quiet", options->quiet, "No progress or summary");
  sub.add_option("command", options->command, "-- PROGRAM ARGS...")->required();
  sub.footer(
      "Examples:\n"
      "  rosguard profile --out /tmp/sort.json --tracer callgrind -- sort -o /dev/null "
      "/etc/services\n"
      "  rosguard profile --out /tmp/ls.json --max-instructions 2000000 --platform orin-agx "
      "--fit-ipc 1.2 -- ls /\n"
      "  (on a calibrated host: --platform host --measure-ipc fits to the program's own run)\n\n"
      "Needs valgrind (Debian package valgrind). lackey writes each trace line with its own "
      "system call (some 1000x the program alone): --max-instructions bounds a long run; "
      "callgrind runs a program of billions of instructions in minutes. The workload holds the "
      "sim profile and, for a whole run, the program as its hw \"command\" (with its \"cwd\"). "
      "Without --fit-ipc or --measure-ipc, base_ipc is a placeholder (1.0) and `rosguard check` "
      "warns of it. Exit 1 when the program fails, with its status.");

  return [options, platform, caches](const CommandContext& c) {
    options->platforms_dir = c.loader.home().platforms();
    options->caches_from_platform = platform->count() > 0 && caches->count() == 0;
    return profile_command(*options, SchemaSet(c.loader.home().schemas()));
  };
}

}  // namespace rosguard

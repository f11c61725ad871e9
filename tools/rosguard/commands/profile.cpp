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
  sub.add_option("--caches", options->caches_kb,
                 "L1,L2,L3 capacities in KB of the target (default 64,256,2048)");
  sub.add_option("--ways", options->ways,
                 "L1,L2,L3 associativity (default 4,8,16: Cortex-A78AE L1D and L2, "
                 "DSU-AE L3)");
  sub.add_option("--name", options->name, "Workload name (default: the program's file name)");
  sub.add_option("--slices-csv", options->slices_csv,
                 "Also write each slice's counts (CSV: first instruction, loads, stores, "
                 "refills, write-backs, L3 misses per MRC capacity) to this file");
  sub.add_flag("--quiet", options->quiet, "No progress or summary");
  sub.add_option("command", options->command, "-- PROGRAM ARGS...")->required();
  sub.footer(
      "Needs valgrind (Debian package valgrind). lackey is slow: it writes each trace line with "
      "its own "
      "system call (about 3 M instructions per CPU second here, some 1000x the program alone); "
      "--max-instructions bounds a long run. "
      "base_ipc is written as a placeholder: fit "
      "it against measured IPC. Exit 1 when the program fails, with its status.");

  return [options](const CommandContext& c) {
    return profile_command(*options, SchemaSet(c.loader.home().schemas()));
  };
}

}  // namespace rosguard

// The rosguard command line: parses argv against the command table (commands/command.h), runs
// the chosen subcommand and turns its errors into exit codes. main() only calls this.
#pragma once

namespace rosguard {

// 0 success, 1 runtime failure, 2 invalid input (usage or scenario), 4 the shard of the results
// folder is being written by another rosguard (run), 130 / 143 interrupted; a subcommand may
// return others (platform model: 3), as its help says.
int run_cli(int argc, char** argv);

}  // namespace rosguard

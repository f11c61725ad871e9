// One subcommand of rosguard: its name and one-line help (what `rosguard --help` lists), the
// CLI11 setup of its arguments, and the handler that runs it once the command line has parsed.
// commands/app.cpp holds the table of them, in the order the help lists them.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <iostream>
#include <memory>
#include <string>

#include "backend/backend.h"
#include "load/loader.h"
#include "policy/policy.h"

namespace rosguard {

// What a handler runs with: made after parsing, so that `--help` and usage errors need no tree.
struct CommandContext {
  Loader& loader;
  const PolicyRegistry& policies;
  const BackendRegistry& backends;
  const std::string& command_line;  // argv joined by spaces, as the manifests record it
};

// A file argument (a scenario, a guard configuration) as the command reads it: a relative path
// that is not in the working folder but is in rosguard's data (Home::data_file) becomes that
// file, with a note on stderr; so `rosguard check scenarios/quickstart.json` runs anywhere.
inline std::string data_argument(const CommandContext& c, const std::string& given) {
  std::string file = c.loader.home().data_file(given);
  if (file != given)
    std::cerr << "note: " << given << " is not in this folder; reading rosguard's own: " << file
              << "\n";
  return file;
}

// Runs the parsed subcommand and returns the process exit code; throws InputError (exit 2),
// ShardBusyError (4) or RunError (1), which the app reports.
using CommandHandler = std::function<int(const CommandContext&)>;

struct Subcommand {
  const char* name;
  const char* help;
  // Adds the arguments, footer and nested subcommands to `sub` (already named and described)
  // and returns its handler, which owns the values the arguments are parsed into.
  CommandHandler (*setup)(CLI::App& sub);
};

// One per file in commands/.
CommandHandler setup_run(CLI::App& sub);
CommandHandler setup_tune(CLI::App& sub);
CommandHandler setup_check(CLI::App& sub);
CommandHandler setup_status(CLI::App& sub);
CommandHandler setup_plot(CLI::App& sub);
CommandHandler setup_compare(CLI::App& sub);
CommandHandler setup_list(CLI::App& sub);
CommandHandler setup_calibrate(CLI::App& sub);
CommandHandler setup_platform(CLI::App& sub);
CommandHandler setup_profile(CLI::App& sub);
CommandHandler setup_guard(CLI::App& sub);

}  // namespace rosguard

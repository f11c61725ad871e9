// `rosguard guard CONFIG.json`: the deployed regulator on this machine (host/guard.h).
#include "host/guard.h"

#include "commands/command.h"

namespace rosguard {

CommandHandler setup_guard(CLI::App& sub) {
  auto args = std::make_shared<GuardArgs>();
  sub.add_option("config", args->config, "Guard configuration (guard.schema.json)")->required();
  sub.add_flag("--check", args->check,
               "Validate the configuration, print it with its defaults; nothing runs");
  return [args](const CommandContext& c) { return guard_command(*args, c.loader, c.policies); };
}

}  // namespace rosguard

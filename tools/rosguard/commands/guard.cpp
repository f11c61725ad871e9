// `rosguard guard CONFIG.json`: the deployed regulator on this machine (host/guard.h).
#include "host/guard.h"

#include "commands/command.h"

namespace rosguard {

CommandHandler setup_guard(CLI::App& sub) {
  auto args = std::make_shared<GuardArgs>();
  sub.add_option("config", args->config, "Guard configuration (guard.schema.json)")->required();
  sub.add_flag("--check", args->check,
               "Validate the configuration, print it with its defaults; nothing runs");
  sub.footer(
      "Examples:\n"
      "  rosguard guard /etc/rosguard/guard.json --check   validate it, print it with every "
      "default\n"
      "  rosguard guard /etc/rosguard/guard.json           regulate until SIGINT / SIGTERM "
      "(logs to stderr)\n"
      "  echo \"planner 1\" > /run/rosguard/activity         an RT job starts (activity.source "
      "fifo)\n"
      "  kill -HUP $(pidof rosguard)                       reload threshold_pct, "
      "regulation_period_us\n"
      "The configuration's keys: guard.schema.json (docs/scenario-reference.md); RT nodes signal "
      "over DDS\nas /rosguard/<name>/active (std_msgs/msg/Bool) from any process or ROS 2 node "
      "(docs/dds.md);\nthe log, DDS Security, reload, stop and crash repair: docs/guard.md.\n"
      "Exit codes: 0 stopped cleanly, 1 a failure at start, 2 an invalid configuration.");
  return [args](const CommandContext& c) { return guard_command(*args, c.loader, c.policies); };
}

}  // namespace rosguard

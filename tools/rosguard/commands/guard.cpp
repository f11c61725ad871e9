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
      "  rosguard guard docs/guard/example.json --check    validate the shipped example (the "
      "paper's Orin),\n"
      "                                                    print it with every default\n"
      "  rosguard guard /etc/rosguard/guard.json           regulate until SIGINT / SIGTERM "
      "(logs to stderr)\n"
      "  echo \"planner 1\" > /run/rosguard/activity         an RT job starts (activity.source "
      "fifo)\n"
      "  kill -HUP $(pidof rosguard)                       reload threshold_pct, "
      "regulation_period_us\n"
      "docs/guard/example.json and the systemd unit docs/guard/rosguard-guard.service (which runs "
      "the guard\non /etc/rosguard/guard.json) are in rosguard's data: an install's "
      "share/rosguard/docs/guard/, read\nfrom there when the working folder has no such file. "
      "The configuration's keys: guard.schema.json\n(docs/scenario-reference.md); RT nodes signal "
      "over DDS as /rosguard/<name>/active (std_msgs/msg/Bool)\nfrom any process or ROS 2 node "
      "(docs/dds.md); the log, DDS Security, reload, stop and crash repair:\ndocs/guard.md.\n"
      "Exit codes: 0 stopped cleanly, 1 a failure at start, 2 an invalid configuration.");
  return [args](const CommandContext& c) {
    args->config = data_argument(c, args->config);
    return guard_command(*args, c.loader, c.policies);
  };
}

}  // namespace rosguard

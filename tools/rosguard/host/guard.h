// `rosguard guard CONFIG.json`: the deployed regulator (hw/guard/guard.h), run until SIGINT /
// SIGTERM (exit 0, every core nominal), reloading CONFIG.json on SIGHUP.
#pragma once

#include <string>

#include "load/loader.h"
#include "policy/policy.h"

namespace rosguard {

struct GuardArgs {
  std::string config;
  bool check = false;  // validate and print the settings; nothing runs
};

int guard_command(const GuardArgs& args, Loader& loader, const PolicyRegistry& policies);

}  // namespace rosguard

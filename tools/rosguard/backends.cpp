// The backends compiled into this build.
#include "commands.h"
#include "sim/register.h"

#ifdef ROSGUARD_WITH_HW
#include "hw/register.h"
#endif

namespace rosguard {

void register_backends(BackendRegistry& registry, const PolicyRegistry& policies) {
  sim::register_builtin(registry, policies);
#ifdef ROSGUARD_WITH_HW
  hw::register_builtin(registry, policies);
#endif
}

}  // namespace rosguard

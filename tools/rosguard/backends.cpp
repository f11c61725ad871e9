// The backends compiled into this build.
#include "commands.h"
#include "sim/register.h"

#ifdef ROSGUARD_WITH_HW
#include "hw/register.h"
#endif

namespace rosguard {

void register_backends(BackendRegistry& registry) {
  sim::register_builtin(registry);
#ifdef ROSGUARD_WITH_HW
  hw::register_builtin(registry);
#endif
}

}  // namespace rosguard

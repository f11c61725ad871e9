// The backends compiled into this build.
#include "commands.h"

#ifdef ROSGUARD_WITH_HW
#include "hw/register.h"
#endif

namespace rosguard {

void register_backends(BackendRegistry& registry) {
#ifdef ROSGUARD_WITH_HW
  hw::register_builtin(registry);
#else
  (void)registry;
#endif
}

}  // namespace rosguard

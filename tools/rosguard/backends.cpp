// The backends compiled into this build (ROSGUARD_WITH_SIM / ROSGUARD_WITH_HW).
#include "backends.h"

#ifdef ROSGUARD_WITH_SIM
#include "sim/register.h"
#endif
#ifdef ROSGUARD_WITH_HW
#include "hw/register.h"
#endif

namespace rosguard {

void register_backends([[maybe_unused]] BackendRegistry& registry,
                       [[maybe_unused]] const PolicyRegistry& policies) {
#ifdef ROSGUARD_WITH_SIM
  sim::register_builtin(registry, policies);
#endif
#ifdef ROSGUARD_WITH_HW
  hw::register_builtin(registry, policies);
#endif
}

}  // namespace rosguard

// The backends compiled into this build.
#include "commands.h"
#include "register.h"

namespace rosguard {

void register_backends(BackendRegistry& registry) {
  sim::register_builtin(registry);
}

}  // namespace rosguard

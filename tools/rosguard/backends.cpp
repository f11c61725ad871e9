// The backends compiled into this build.
#include "commands.h"

namespace rosguard {

void register_backends(BackendRegistry&) {}

}  // namespace rosguard

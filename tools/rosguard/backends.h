// The backends an executable registers: backends.cpp (sim and hw, as built) in rosguard, fake
// ones in the test binaries.
#pragma once

#include "backend/backend.h"
#include "policy/policy.h"

namespace rosguard {

// Every backend this build has (sim and hw when they are compiled in).
void register_backends(BackendRegistry& registry, const PolicyRegistry& policies);

}  // namespace rosguard

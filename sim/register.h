// Registration of the sim backend (called from tools/rosguard/backends.cpp and test setup).
#pragma once

#include "backend/backend.h"
#include "policy/policy.h"

namespace rosguard::sim {

// Adds the "sim" backend; it runs the policies of `policies`, which must outlive `registry`.
void register_builtin(BackendRegistry& registry, const PolicyRegistry& policies);

}  // namespace rosguard::sim

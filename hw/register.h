// Registration of the hw backend and its PMC sources (explicit: no static self-registration).
#pragma once

#include "backend/backend.h"
#include "hw/pmc_source/pmc_source.h"
#include "policy/policy.h"

namespace rosguard::hw {

// Adds the "hw" backend; it runs the policies of `policies`, which must outlive `registry`.
void register_builtin(BackendRegistry& registry, const PolicyRegistry& policies);

}  // namespace rosguard::hw

// Registration of the hw backend and its PMC sources (explicit: no static self-registration).
#pragma once

#include "backend/backend.h"
#include "hw/pmc_source/pmc_source.h"

namespace rosguard::hw {

// Adds the "hw" backend.
void register_builtin(BackendRegistry& registry);

}  // namespace rosguard::hw

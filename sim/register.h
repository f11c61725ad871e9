// Registration of the sim backend (called from tools/rosguard/backends.cpp and test setup).
#pragma once

#include "backend/backend.h"

namespace rosguard::sim {

void register_builtin(BackendRegistry& registry);

}  // namespace rosguard::sim

// A registry of the built-in policies, made once: for tests and benchmarks. A run makes its own
// (tools/rosguard: register_builtin into the registry the backends are given), to which a program
// embedding rosguard may add policies.
#pragma once

#include "policy/policy.h"

namespace rosguard {

inline const PolicyRegistry& builtin_registry() {
  static const PolicyRegistry registry = [] {
    PolicyRegistry r;
    register_builtin(r);
    return r;
  }();
  return registry;
}

}  // namespace rosguard

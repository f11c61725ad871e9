#include "register.h"

#include "backend.h"

namespace rosguard::sim {

void register_builtin(BackendRegistry& registry, const PolicyRegistry& policies) {
  registry.add({"sim",
                "SystemC model of the Jetson AGX Orin CPU complex: 3 x 4 Cortex-A78AE, "
                "per-cluster L3, shared DRAM, ROS 2 middleware costs",
                [&policies] { return std::make_unique<SimBackend>(policies); }});
}

}  // namespace rosguard::sim

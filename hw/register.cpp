#include "hw/register.h"

#include "hw/backend.h"

namespace rosguard::hw {

void register_builtin(BackendRegistry& registry, const PolicyRegistry& policies) {
  registry.add({"hw",
                "this Linux machine: pthread executors (SCHED_FIFO, affinity), perf_event_open / "
                "instrumented counters, the paper's throttle",
                [&policies] { return make_hw_backend(policies); }});
}

}  // namespace rosguard::hw

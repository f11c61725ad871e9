// SystemC plumbing shared by every component of one simulation: simulated time in integer ns,
// a trap for exceptions thrown inside processes, an activation counter, timers and the message
// bus.
//
// Contract: one Runtime per elaboration (one per process: SystemC cannot elaborate twice).
// Process bodies run inside Runtime::guarded(): the first exception stops the simulation
// (sc_stop) and is rethrown by Runtime::run() once sc_start() has returned, because exceptions
// must not cross the SystemC kernel.
#pragma once

#include <cstdint>
#include <exception>
#include <functional>
#include <queue>
#include <string>
#include <systemc>
#include <vector>

#include "core/types.h"

namespace rosguard::sim {

// Simulated time now, in ns (the kernel's resolution is 1 ps; every time here is whole ns).
TimeNs now_ns();
sc_core::sc_time to_sc(TimeNs ns);

class Runtime {
 public:
  Runtime();
  Runtime(const Runtime&) = delete;
  Runtime& operator=(const Runtime&) = delete;

  // Runs one process activation: counts it, traps exceptions.
  template <class F>
  void guarded(F&& f) {
    ++activations_;
    if (failed_) return;
    try {
      f();
    } catch (...) {
      fail(std::current_exception());
    }
  }
  // Ends the simulation at the current time (idempotent).
  void stop();
  bool stopped() const { return stopped_; }
  void fail(std::exception_ptr e);
  // sc_start() until stop() or `limit_ns` of simulated time; rethrows a trapped exception.
  // Returns false when the limit was reached first.
  bool run(TimeNs limit_ns);
  std::uint64_t activations() const { return activations_; }

 private:
  std::uint64_t activations_ = 0;
  bool stopped_ = false;
  bool failed_ = false;
  std::exception_ptr error_;
};

// A one-shot, re-armable alarm: calls `fn(now)` at the time last set.
class Timer : public sc_core::sc_module {
 public:
  SC_HAS_PROCESS(Timer);
  using Fn = std::function<void(TimeNs)>;
  Timer(const sc_core::sc_module_name& name, Runtime& rt, Fn fn);
  // Fires at `at` (>= now), replacing any earlier setting.
  void set(TimeNs at);
  void cancel();
  bool pending() const { return at_ >= 0; }
  TimeNs when() const { return at_; }

 private:
  void fire();
  Runtime& rt_;
  Fn fn_;
  sc_core::sc_event ev_;
  TimeNs at_ = -1;
};

// Messages between nodes (publish-subscribe topics). Each link delivers in order (DDS reliable
// topics keep the order of one writer): a message never overtakes an earlier one on its link.
class MessageBus : public sc_core::sc_module {
 public:
  SC_HAS_PROCESS(MessageBus);
  using Deliver = std::function<void(TimeNs)>;
  MessageBus(const sc_core::sc_module_name& name, Runtime& rt);
  // A new link id (one per topic and direction).
  int add_link();
  // Sent at `depart`, arrives `latency` later (or right after the link's previous message).
  // Returns the arrival time.
  TimeNs send(int link, TimeNs depart, TimeNs latency, Deliver deliver);

 private:
  struct Item {
    TimeNs at;
    std::uint64_t seq;
    Deliver deliver;
    bool operator>(const Item& o) const { return at != o.at ? at > o.at : seq > o.seq; }
  };
  void deliver();
  Runtime& rt_;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> queue_;
  std::vector<TimeNs> last_arrival_;
  std::uint64_t seq_ = 0;
  sc_core::sc_event ev_;
  TimeNs armed_ = -1;
};

}  // namespace rosguard::sim

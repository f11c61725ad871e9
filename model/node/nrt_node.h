// The nRT node state machine of ROSGuard, shared by both backends.
//
// States: OFF (nominal), ON (nominal + PMC sampling when self-sampling), THR (throttled).
// Callbacks, highest priority first: CFB (command) > THR (idle loop) > PMC (sampling) > NCT
// (nominal work): the simulated core (sim/platform/core.h) and the threads' priorities
// (hw/executor/executor.h) order them. The nRT engine (model/engine/nrt_driver.h) calls apply()
// for each command received.
// Contract: not thread-safe; one owner (the node's CFB executor, or the simulated core).
#pragma once

#include <cstdint>
#include <string_view>

#include "core/types.h"

namespace rosguard {

enum class NodeState : std::uint8_t { Off, On, Thr };

std::string_view to_string(NodeState s);

struct Transition {
  NodeState from;
  NodeState to;
  bool changed() const { return from != to; }
};

class NrtNode {
 public:
  explicit NrtNode(Sampling sampling) : sampling_(sampling) {}

  NodeState state() const { return state_; }
  Sampling sampling() const { return sampling_; }

  // The CFB callback's work. Rules:
  //   OFF       any -> OFF (nominal)
  //   ON        OFF -> ON; THR -> ON (a new activation releases the throttle); ON stays
  //   THR       ON -> THR; ignored in OFF (never throttle outside an activation); THR stays
  //   REPLENISH THR -> ON; otherwise ignored
  Transition apply(Command command);

 private:
  Sampling sampling_;
  NodeState state_ = NodeState::Off;
};

}  // namespace rosguard

// The nRT node state machine of ROSGuard, shared by both backends.
//
// States: OFF (nominal), ON (nominal + PMC sampling when self-sampling), THR (throttled).
// Callbacks, highest priority first: CFB (command) > THR (idle loop) > PMC (sampling) > NCT
// (nominal work). The host (a SystemC process or the CFB thread of the hw backend) calls
// apply() for each command received and dispatch() to learn which callback runs next.
// Contract: not thread-safe; one owner (the node's CFB executor, or the simulated core).
#pragma once

#include <cstdint>
#include <string_view>

#include "core/types.h"

namespace rosguard {

enum class NodeState : std::uint8_t { Off, On, Thr };
enum class Callback : std::uint8_t { None, Cfb, Thr, Pmc, Nct };

std::string_view to_string(NodeState s);
std::string_view to_string(Callback c);

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

  // Whether the PMC callback is enabled: self-sampling in state ON (THR preempts it).
  bool sampling_enabled() const { return sampling_ == Sampling::Self && state_ == NodeState::On; }

  // Which callback runs, given what is ready: CFB whenever a command is pending; then THR in
  // state THR; then PMC when a sample is due and sampling is enabled; then NCT if it has work.
  Callback dispatch(bool command_pending, bool sample_due, bool work_ready) const;

 private:
  Sampling sampling_;
  NodeState state_ = NodeState::Off;
};

}  // namespace rosguard

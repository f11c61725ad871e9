#include "node/nrt_node.h"

namespace rosguard {

std::string_view to_string(NodeState s) {
  switch (s) {
    case NodeState::Off:
      return "OFF";
    case NodeState::On:
      return "ON";
    case NodeState::Thr:
      return "THR";
  }
  return "?";
}

std::string_view to_string(Callback c) {
  switch (c) {
    case Callback::None:
      return "idle";
    case Callback::Cfb:
      return "CFB";
    case Callback::Thr:
      return "THR";
    case Callback::Pmc:
      return "PMC";
    case Callback::Nct:
      return "NCT";
  }
  return "?";
}

Transition NrtNode::apply(Command command) {
  const NodeState from = state_;
  switch (command) {
    case Command::Off:
      state_ = NodeState::Off;
      break;
    case Command::On:
      state_ = NodeState::On;
      break;
    case Command::Thr:
      if (state_ == NodeState::On) state_ = NodeState::Thr;
      break;
    case Command::Replenish:
      if (state_ == NodeState::Thr) state_ = NodeState::On;
      break;
  }
  return {from, state_};
}

Callback NrtNode::dispatch(bool command_pending, bool sample_due, bool work_ready) const {
  if (command_pending) return Callback::Cfb;
  if (state_ == NodeState::Thr) return Callback::Thr;
  if (sample_due && sampling_enabled()) return Callback::Pmc;
  if (work_ready) return Callback::Nct;
  return Callback::None;
}

}  // namespace rosguard

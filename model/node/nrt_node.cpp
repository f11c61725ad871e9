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

}  // namespace rosguard

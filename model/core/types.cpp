#include "core/types.h"

namespace rosguard {

std::string_view to_string(Command c) {
  switch (c) {
    case Command::On:
      return "ON";
    case Command::Off:
      return "OFF";
    case Command::Thr:
      return "THR";
    case Command::Replenish:
      return "REPLENISH";
  }
  return "?";
}

std::string_view to_string(Sampling s) {
  switch (s) {
    case Sampling::Self:
      return "self";
    case Sampling::External:
      return "external";
    case Sampling::Overflow:
      return "overflow";
    case Sampling::Mmio:
      return "mmio";
  }
  return "?";
}

std::string_view to_string(Scope s) {
  switch (s) {
    case Scope::Core:
      return "core";
    case Scope::Node:
      return "node";
    case Scope::Group:
      return "group";
  }
  return "?";
}

std::string_view to_string(Sharing s) {
  switch (s) {
    case Sharing::Off:
      return "off";
    case Sharing::Last:
      return "last";
    case Sharing::All:
      return "all";
  }
  return "?";
}

}  // namespace rosguard

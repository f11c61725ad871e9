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
  return s == Sampling::Self ? "self" : "external";
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

}  // namespace rosguard

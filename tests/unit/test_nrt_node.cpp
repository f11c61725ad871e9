// The nRT node state machine (node/nrt_node.h): every (state, command) transition. Which
// callback runs (CFB > THR > PMC > NCT) is the hosts' (sim core, hw thread priorities).
#include <catch2/catch.hpp>

#include "node/nrt_node.h"
#include "regulator_support.h"

using namespace rosguard;

namespace {

NrtNode node_in(NodeState s, Sampling sampling = Sampling::Self) {
  NrtNode n(sampling);
  if (s != NodeState::Off) n.apply(Command::On);
  if (s == NodeState::Thr) n.apply(Command::Thr);
  REQUIRE(n.state() == s);
  return n;
}

}  // namespace

TEST_CASE("nRT node: starts OFF", "[node]") {
  CHECK(NrtNode(Sampling::Self).state() == NodeState::Off);
  CHECK(NrtNode(Sampling::External).state() == NodeState::Off);
  CHECK(NrtNode(Sampling::External).sampling() == Sampling::External);
}

TEST_CASE("nRT node: every (state, command) transition", "[node]") {
  using S = NodeState;
  using C = Command;
  struct Row {
    S from;
    C command;
    S to;
  };
  const Row table[] = {
      // OFF from any state returns to nominal.
      {S::Off, C::Off, S::Off},
      {S::On, C::Off, S::Off},
      {S::Thr, C::Off, S::Off},
      // ON: OFF -> ON; THR -> ON (a new activation releases the throttle); ON stays.
      {S::Off, C::On, S::On},
      {S::On, C::On, S::On},
      {S::Thr, C::On, S::On},
      // THR: ON -> THR; ignored in OFF (never throttle outside an activation); THR stays.
      {S::Off, C::Thr, S::Off},
      {S::On, C::Thr, S::Thr},
      {S::Thr, C::Thr, S::Thr},
      // REPLENISH: THR -> ON, otherwise ignored.
      {S::Off, C::Replenish, S::Off},
      {S::On, C::Replenish, S::On},
      {S::Thr, C::Replenish, S::On},
  };
  for (const Row& r : table) {
    for (Sampling sampling : {Sampling::Self, Sampling::External}) {
      INFO(to_string(r.from) << " + " << to_string(r.command) << " (" << to_string(sampling)
                             << " sampling)");
      NrtNode n = node_in(r.from, sampling);
      const Transition tr = n.apply(r.command);
      CHECK(tr.from == r.from);
      CHECK(tr.to == r.to);
      CHECK(tr.changed() == (r.from != r.to));
      CHECK(n.state() == r.to);
    }
  }
}

TEST_CASE("nRT node: states have printable names", "[node]") {
  CHECK(to_string(NodeState::Off) == "OFF");
  CHECK(to_string(NodeState::On) == "ON");
  CHECK(to_string(NodeState::Thr) == "THR");
  CHECK(to_string(Command::Replenish) == "REPLENISH");
}

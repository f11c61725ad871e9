// The nRT node state machine (node/nrt_node.h): every (state, command) transition, and which
// callback runs by priority CFB > THR > PMC > NCT.
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

TEST_CASE("nRT node: PMC sampling only in ON with self-sampling", "[node]") {
  CHECK_FALSE(node_in(NodeState::Off).sampling_enabled());
  CHECK(node_in(NodeState::On).sampling_enabled());
  CHECK_FALSE(node_in(NodeState::Thr).sampling_enabled());  // THR preempts PMC
  CHECK_FALSE(node_in(NodeState::Off, Sampling::External).sampling_enabled());
  CHECK_FALSE(node_in(NodeState::On, Sampling::External).sampling_enabled());
  CHECK_FALSE(node_in(NodeState::Thr, Sampling::External).sampling_enabled());
}

TEST_CASE("nRT node: dispatch priority CFB > THR > PMC > NCT", "[node]") {
  using Cb = Callback;
  SECTION("a pending command always runs CFB first") {
    for (NodeState s : {NodeState::Off, NodeState::On, NodeState::Thr})
      for (bool sample : {false, true})
        for (bool work : {false, true})
          CHECK(node_in(s).dispatch(true, sample, work) == Cb::Cfb);
  }
  SECTION("THR: the idle loop preempts PMC and NCT, and runs even with nothing ready") {
    const NrtNode n = node_in(NodeState::Thr);
    CHECK(n.dispatch(false, true, true) == Cb::Thr);
    CHECK(n.dispatch(false, false, true) == Cb::Thr);
    CHECK(n.dispatch(false, true, false) == Cb::Thr);
    CHECK(n.dispatch(false, false, false) == Cb::Thr);
  }
  SECTION("ON with self-sampling: PMC before NCT") {
    const NrtNode n = node_in(NodeState::On);
    CHECK(n.dispatch(false, true, true) == Cb::Pmc);
    CHECK(n.dispatch(false, true, false) == Cb::Pmc);
    CHECK(n.dispatch(false, false, true) == Cb::Nct);
    CHECK(n.dispatch(false, false, false) == Cb::None);
  }
  SECTION("ON with external sampling: no PMC callback") {
    const NrtNode n = node_in(NodeState::On, Sampling::External);
    CHECK(n.dispatch(false, true, true) == Cb::Nct);
    CHECK(n.dispatch(false, true, false) == Cb::None);
  }
  SECTION("OFF: nominal work only, never PMC") {
    const NrtNode n = node_in(NodeState::Off);
    CHECK(n.dispatch(false, true, true) == Cb::Nct);
    CHECK(n.dispatch(false, true, false) == Cb::None);
    CHECK(n.dispatch(false, false, true) == Cb::Nct);
  }
}

TEST_CASE("nRT node: states and callbacks have printable names", "[node]") {
  CHECK(to_string(NodeState::Off) == "OFF");
  CHECK(to_string(NodeState::On) == "ON");
  CHECK(to_string(NodeState::Thr) == "THR");
  CHECK(to_string(Callback::Cfb) == "CFB");
  CHECK(to_string(Callback::Thr) == "THR");
  CHECK(to_string(Callback::Pmc) == "PMC");
  CHECK(to_string(Callback::Nct) == "NCT");
  CHECK(to_string(Command::Replenish) == "REPLENISH");
}

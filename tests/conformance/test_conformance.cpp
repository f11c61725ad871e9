// Conformance of the two controller shells: one scripted trace of RT signals, samples and
// counter values is fed to the sim controller (sim/nodes/controller.h, a SystemC module) and to
// the hw controller (hw/nodes/controller.h, driven through its topics with an injected clock and
// fake counters). Both must send the same commands to each entity, with the same causes, and
// account the same regulation-active time and traffic.
//
// Time: the sim charges every controller callback and every message at least 1 ns (its minimum
// cost; the costs here are all zero). So the hw rig serves each input 1 ns after it arrives, as
// the sim does, and its counter read takes 1 ns of the fake clock, as the sim's read does. Commands
// are compared as (command, cause) per entity; the cause (the measurement time of the sample that
// made the regulator act) is the same in both shells by construction of the driver, the time a
// command is published is a shell's own cost.
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cstdlib>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <systemc>
#include <vector>

#include "hw/nodes/controller.h"
#include "kernel/runtime.h"
#include "nodes/controller.h"
#include "policy/policy.h"

using namespace rosguard;
using nlohmann::json;

namespace {

constexpr TimeNs ms(double v) {
  return static_cast<TimeNs>(v * 1e6);
}

struct Input {
  enum class Kind { Start, Stop, Sample } kind;
  TimeNs at = 0;
  std::size_t entity = 0;
  std::uint64_t lines = 0;
  TimeNs measured = 0;
};

// Cumulative L2 refills of an entity: steps (from time, value).
using Traffic = std::vector<std::pair<TimeNs, std::uint64_t>>;

struct Script {
  Sampling sampling = Sampling::Self;
  TimeNs sampling_period_ns = ms(1);
  std::size_t entities = 1;
  std::vector<Input> inputs;  // in time order
  std::vector<Traffic> traffic;
  TimeNs end = ms(20);
  // The policy: interval at 20 % of 1000 MB/s over 5 ms unless a script says otherwise.
  std::function<std::unique_ptr<Policy>()> policy;

  std::uint64_t lines_at(std::size_t e, TimeNs t) const {
    std::uint64_t v = 0;
    for (const auto& [from, value] : traffic.at(e))
      if (from <= t) v = value;
    return v;
  }
  std::unique_ptr<Regulator> regulator() const {
    PolicyParams p;
    p.threshold_pct = 20.0;  // 20 % of 1000 MB/s over 5 ms: 16 384 lines of 64 B
    p.reference_mbps = 1000.0;
    p.regulation_period_ns = ms(5);
    RegulatorConfig rc;
    rc.account_of_entity = accounts_for_scope(Scope::Core, entities);
    return std::make_unique<Regulator>(rc, policy ? policy() : make_interval_policy(p));
  }
};

std::vector<CounterValue> counters(std::uint64_t lines, TimeNs t) {
  const auto u = static_cast<std::uint64_t>(t);
  return {{lines, u, u}, {0, u, u}};
}

// What a shell did: per entity, (command, cause) in order; and the driver's accounting.
json summary(const std::vector<std::vector<std::pair<Command, TimeNs>>>& commands,
             const ControllerDriver& d) {
  json j;
  for (const auto& seq : commands) {
    json s = json::array();
    for (const auto& [c, cause] : seq)
      s.push_back({std::string(to_string(c)), cause});
    j["commands"].push_back(s);
  }
  j["activations"] = d.totals().activations;
  j["active_ns"] = d.totals().active_ns;
  for (std::size_t e = 0; e < d.entity_count(); ++e) {
    j["active_bytes"].push_back(d.totals().active[e].bytes);
    j["throttles"].push_back(d.regulator().entity(e).throttles);
  }
  return j;
}

// --- the sim shell, in a forked child (SystemC elaborates once per process) ----------------------

json run_sim(const Script& script) {
  using namespace rosguard::sim;
  ::setenv("SC_COPYRIGHT_MESSAGE", "DISABLE", 1);
  Runtime rt;
  MessageBus bus("bus", rt);
  Recorder rec;
  CostParams zero;  // every cost constant 0: the sim's 1 ns minimum
  ControllerConfig cc;
  cc.sampling = script.sampling;
  cc.sampling_period_ns = script.sampling_period_ns;
  cc.metric_events = {PmuEvent::L2Refill, PmuEvent::L2Wb};
  Controller ctl("controller", cc, script.regulator(), zero, 1, bus, rt, rec);
  std::vector<Pmu> pmus(script.entities);
  std::vector<std::vector<std::pair<Command, TimeNs>>> got(script.entities);
  for (std::size_t e = 0; e < script.entities; ++e)
    ctl.add_entity({"nrt" + std::to_string(e), 0,  // as the hw shell's entity_cores below
                    [&got, e](Command c, TimeNs cause) { got[e].emplace_back(c, cause); },
                    [&pmus, &script, e]() -> const Pmu& {
                      pmus[e][PmuEvent::L2Refill] =
                          static_cast<double>(script.lines_at(e, rosguard::sim::now_ns()));
                      return pmus[e];
                    }});
  std::size_t next = 0;
  Timer* feed = nullptr;
  Timer feeder("feeder", rt, [&](TimeNs now) {
    while (next < script.inputs.size() && script.inputs[next].at <= now) {
      const Input& in = script.inputs[next++];
      if (in.kind == Input::Kind::Start) ctl.enable(0, now, ctl.core());
      if (in.kind == Input::Kind::Stop) ctl.disable(0, now, ctl.core());
      if (in.kind == Input::Kind::Sample)
        ctl.sample(in.entity, counters(in.lines, in.measured), in.measured, now);
    }
    if (next < script.inputs.size())
      feed->set(script.inputs[next].at);
    else
      feed->set(script.end);
    if (now >= script.end) rt.stop();
  });
  feed = &feeder;
  struct Kick : sc_core::sc_module {
    SC_HAS_PROCESS(Kick);
    Kick(const sc_core::sc_module_name& n, Timer& t, TimeNs at) : sc_module(n), t_(t), at_(at) {
      SC_METHOD(go);
    }
    void go() { t_.set(at_); }
    Timer& t_;
    TimeNs at_;
  } kick("kick", feeder, script.inputs.front().at);
  rt.run(script.end + ms(1));
  return summary(got, ctl.driver());
}

json sim_in_child(const Script& script) {
  int fds[2];
  REQUIRE(::pipe(fds) == 0);
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    ::close(fds[0]);
    std::string out;
    try {
      out = run_sim(script).dump();
    } catch (const std::exception& e) {
      out = json{{"error", e.what()}}.dump();
    }
    std::size_t done = 0;
    while (done < out.size()) {
      const ssize_t n = ::write(fds[1], out.data() + done, out.size() - done);
      if (n <= 0) break;
      done += static_cast<std::size_t>(n);
    }
    ::_exit(0);
  }
  ::close(fds[1]);
  std::string text;
  char buf[4096];
  ssize_t n;
  while ((n = ::read(fds[0], buf, sizeof buf)) > 0)
    text.append(buf, static_cast<std::size_t>(n));
  ::close(fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  REQUIRE(WIFEXITED(status));
  const json j = json::parse(text);
  INFO(j.dump());
  REQUIRE_FALSE(j.contains("error"));
  return j;
}

// --- the hw shell, on this thread, with an injected clock
// -----------------------------------------

struct FakeGroup : hw::CounterGroup {
  const Script& script;
  std::size_t entity;
  TimeNs& clock;
  FakeGroup(const Script& s, std::size_t e, TimeNs& c) : script(s), entity(e), clock(c) {}
  std::size_t size() const override { return 2; }
  void read(std::span<CounterValue> out) override {
    clock += 1;  // a read takes 1 ns, as the sim's cheapest read does
    const auto v = counters(script.lines_at(entity, clock), clock);
    std::copy(v.begin(), v.end(), out.begin());
  }
};

struct FakeMeter : EntityMeter {
  const Script& script;
  explicit FakeMeter(const Script& s) : script(s) {}
  EntityReading read(std::size_t e, TimeNs t) override {
    return {static_cast<double>(script.lines_at(e, t)) * 64.0, 0.0, 0.0};
  }
};

json run_hw(const Script& script) {
  TimeNs clock = 0;
  hw::InprocTopic<hw::RtEventMsg> rt_topic;
  hw::InprocTopic<hw::SampleMsg> samples;
  std::vector<std::unique_ptr<hw::Topic<hw::ControlMsg>>> controls;
  std::vector<hw::Topic<hw::ControlMsg>*> control_ptrs;
  hw::Waker listener, engine;
  std::vector<std::size_t> subs;
  for (std::size_t e = 0; e < script.entities; ++e) {
    controls.push_back(std::make_unique<hw::InprocTopic<hw::ControlMsg>>());
    control_ptrs.push_back(controls.back().get());
    subs.push_back(controls.back()->subscribe(listener));
  }
  const std::size_t rt_pub = rt_topic.add_publisher();
  const std::size_t sample_pub = samples.add_publisher();
  hw::ControllerConfig cc;
  cc.sampling = script.sampling;
  cc.sampling_period_ns = script.sampling_period_ns;
  cc.keepalive_ns = 0;
  cc.metric_events = 2;
  cc.entity_cores.assign(script.entities, 0);
  cc.group_sizes.assign(script.entities, 2);
  cc.clock = [&clock] { return clock; };
  FakeMeter meter(script);
  hw::Controller ctl(cc, script.regulator(), rt_topic, samples, control_ptrs, &meter, engine, {},
                     0);
  std::vector<std::unique_ptr<FakeGroup>> groups;
  std::vector<hw::CounterGroup*> group_ptrs;
  for (std::size_t e = 0; e < script.entities; ++e) {
    groups.push_back(std::make_unique<FakeGroup>(script, e, clock));
    group_ptrs.push_back(groups.back().get());
  }
  ctl.set_groups(group_ptrs);

  const auto advance_to = [&](TimeNs t) {
    while (true) {
      const auto due = ctl.driver().next_wakeup();
      if (!due || *due > t) break;
      clock = std::max(clock, *due);
      ctl.serve();
    }
    clock = std::max(clock, t);
  };
  for (const Input& in : script.inputs) {
    advance_to(in.at);
    if (in.kind == Input::Kind::Sample) {
      hw::SampleMsg m;
      m.entity = in.entity;
      m.t_published = in.measured;
      m.count = 2;
      const auto c = counters(in.lines, in.measured);
      std::copy(c.begin(), c.end(), m.counters.begin());
      samples.publish(sample_pub, m);
    } else {
      rt_topic.publish(rt_pub, {0, in.kind == Input::Kind::Start, in.at});
    }
    clock = std::max(clock, in.at + 1);  // served 1 ns after it arrives, as in the sim
    ctl.serve();
  }
  advance_to(script.end);
  std::vector<std::vector<std::pair<Command, TimeNs>>> got(script.entities);
  for (std::size_t e = 0; e < script.entities; ++e) {
    hw::ControlMsg m;
    while (controls[e]->take(subs[e], m))
      if (m.kind == hw::ControlMsg::Kind::Command) got[e].emplace_back(m.command, m.t_cause);
  }
  return summary(got, ctl.driver());
}

// --- the scripts ---------------------------------------------------------------------------------

Input start(double at) {
  return {Input::Kind::Start, ms(at)};
}
Input stop(double at) {
  return {Input::Kind::Stop, ms(at)};
}
Input sample(double at, std::size_t e, std::uint64_t lines, double measured) {
  return {Input::Kind::Sample, ms(at), e, lines, ms(measured)};
}

// Self-sampling, two entities: entity 0 exceeds its budget twice, entity 1 never.
Script self_sampling_script() {
  Script s;
  s.entities = 2;
  s.inputs = {start(1.0),
              sample(1.1, 0, 0, 1.05),
              sample(1.2, 1, 0, 1.15),
              sample(2.1, 0, 10000, 2.05),
              sample(3.1, 0, 20000, 3.05),
              sample(3.6, 1, 5000, 3.55),
              sample(7.1, 0, 25000, 7.05),
              sample(8.1, 0, 45000, 8.05),
              sample(9.1, 1, 9000, 9.05),
              stop(12.5)};
  s.traffic = {{{0, 0}, {ms(2), 10000}, {ms(3), 20000}, {ms(7), 25000}, {ms(8), 45000}},
               {{0, 0}, {ms(3.5), 5000}, {ms(9), 9000}}};
  s.end = ms(14);
  return s;
}

// External sampling, one entity, read every 0.7 ms (never on a 5 ms window boundary): a steady
// stream of traffic that exceeds the budget in every window.
Script external_sampling_script() {
  Script s;
  s.sampling = Sampling::External;
  s.sampling_period_ns = ms(0.7);
  s.entities = 1;
  s.inputs = {start(1.0), stop(14.2)};
  Traffic t{{0, 0}};
  for (int k = 1; k < 60; ++k)
    t.emplace_back(ms(1.0) + k * ms(0.25) + 137, static_cast<std::uint64_t>(k) * 2500);
  s.traffic = {t};
  s.end = ms(16);
  return s;
}

// MemPol's rules through external sampling (the hw backend's stand-in for its polling), two
// entities streaming some 50 000 and 33 000 lines per 5 ms: each under its share (1000 MB/s
// over 5 ms: 81 920 lines), together over the global cap (700 MB/s: 57 344 lines), so both are
// throttled together.
Script mempol_script() {
  Script s = external_sampling_script();
  s.entities = 2;
  Traffic other{{0, 0}};
  for (int k = 1; k < 60; ++k)
    other.emplace_back(ms(1.0) + k * ms(0.3) + 59, static_cast<std::uint64_t>(k) * 2000);
  s.traffic.push_back(other);
  s.policy = [] {
    PolicyParams p;
    p.regulation_period_ns = ms(5);
    p.budget_mbps = {1000.0};
    p.global_budget_mbps = 700.0;
    return make_mempol_policy(p);
  };
  return s;
}

void check_same(const json& sim, const json& hw) {
  INFO("sim: " << sim.dump());
  INFO("hw:  " << hw.dump());
  // Not vacuous: regulation acted (ON, THR, REPLENISH, OFF all occur).
  const std::string all = sim["commands"].dump();
  for (const char* c : {"ON", "THR", "REPLENISH", "OFF"})
    CHECK(all.find(c) != std::string::npos);
  CHECK(sim["commands"] == hw["commands"]);
  CHECK(sim["activations"] == hw["activations"]);
  CHECK(sim["active_ns"] == hw["active_ns"]);
  CHECK(sim["active_bytes"] == hw["active_bytes"]);
  CHECK(sim["throttles"] == hw["throttles"]);
}

}  // namespace

TEST_CASE("conformance: self-sampling trace, sim and hw controllers agree", "[conformance]") {
  const Script s = self_sampling_script();
  check_same(sim_in_child(s), run_hw(s));
}

TEST_CASE("conformance: external-sampling trace, sim and hw controllers agree", "[conformance]") {
  const Script s = external_sampling_script();
  check_same(sim_in_child(s), run_hw(s));
}

TEST_CASE("conformance: mempol's global cap over two entities, sim and hw controllers agree",
          "[conformance]") {
  const Script s = mempol_script();
  const json sim = sim_in_child(s);
  check_same(sim, run_hw(s));
  // The cap, not a share, throttled them: each entity got THR at the same time.
  const auto& c = sim["commands"];
  REQUIRE(c.size() == 2);
  std::vector<json> thr0, thr1;
  for (const auto& x : c[0])
    if (x[0] == "THR") thr0.push_back(x);
  for (const auto& x : c[1])
    if (x[0] == "THR") thr1.push_back(x);
  CHECK_FALSE(thr0.empty());
  CHECK(thr0 == thr1);
}

// The regulator under long randomized (fixed-seed) input sequences: determinism, and invariants
// that must hold after every call whatever the inputs.
#include <catch2/catch.hpp>
#include <cstdint>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "regulator_support.h"

using namespace rosguard;
using namespace rosguard::test;

namespace {

struct Setup {
  std::string policy;  // interval | monolithic | monitor | none
  Scope scope = Scope::Core;
  std::size_t entities = 3;
  std::size_t rt_count = 2;
  unsigned counter_bits = 64;
};

std::unique_ptr<Policy> make_policy(const std::string& name) {
  const PolicyParams p = params(kPeriod, ms(12));
  if (name == "interval") return make_interval_policy(p);
  if (name == "monolithic") return make_monolithic_policy(p);
  if (name == "monitor") return make_monitor_policy(p);
  return make_none_policy(p);
}

Setup random_setup(std::mt19937_64& rng) {
  static const char* const policies[] = {"interval", "monolithic", "monitor", "none"};
  static const Scope scopes[] = {Scope::Core, Scope::Node, Scope::Group};
  Setup s;
  s.policy = policies[rng() % 4];
  s.scope = scopes[rng() % 3];
  s.entities = 1 + rng() % 4;
  s.rt_count = 1 + rng() % 3;
  s.counter_bits = rng() % 3 == 0 ? 32 : 64;
  return s;
}

struct Input {
  enum Kind { Start, Finish, Sample, Tick } kind;
  TimeNs t;
  std::size_t index;  // RT node or entity
  std::vector<CounterValue> counters;
};

// Plays a host: RT nodes start and finish, entities are sampled (sometimes multiplexed, 32-bit
// counters wrap), ticks come at the boundaries the regulator asks for, but sometimes late or
// not at all (catch-up), sometimes several inputs share one t.
class Host {
 public:
  Host(const Setup& setup, std::uint64_t seed)
      : setup_(setup),
        rng_(seed),
        running_(setup.rt_count, false),
        counters_(setup.entities, std::vector<CounterValue>(2)) {}

  Input next(const Regulator& reg) {
    const TimeNs dt = rng_() % 8 == 0 ? 0 : static_cast<TimeNs>(1 + rng_() % us(2000));
    const TimeNs t = now_ + dt;
    if (const auto tick = reg.next_tick(); tick && *tick <= t && rng_() % 10 < 7) {
      now_ = *tick;
      return {Input::Tick, *tick, 0, {}};
    }
    now_ = t;
    const auto roll = rng_() % 100;
    if (roll < 8) {
      const std::size_t rt = rng_() % setup_.rt_count;
      running_[rt] = !running_[rt];
      return {running_[rt] ? Input::Start : Input::Finish, t, rt, {}};
    }
    if (roll < 12) return {Input::Tick, t, 0, {}};
    const std::size_t e = rng_() % setup_.entities;
    auto& c = counters_[e];
    const bool multiplexed = rng_() % 4 == 0;
    for (auto& v : c) {
      v.value += rng_() % 9000;  // up to ~4.6 budgets per ms
      if (setup_.counter_bits == 32) v.value &= 0xffffffffULL;
      v.time_enabled_ns += static_cast<std::uint64_t>(dt);
      v.time_running_ns += multiplexed ? static_cast<std::uint64_t>(dt) / (1 + rng_() % 4)
                                       : static_cast<std::uint64_t>(dt);
    }
    return {Input::Sample, t, e, c};
  }

 private:
  Setup setup_;
  std::mt19937_64 rng_;
  std::vector<bool> running_;
  std::vector<std::vector<CounterValue>> counters_;
  TimeNs now_ = 0;
};

void apply(Regulator& reg, const Input& in, Commands& out) {
  switch (in.kind) {
    case Input::Start:
      reg.rt_started(in.t, in.index, out);
      break;
    case Input::Finish:
      reg.rt_finished(in.t, in.index, out);
      break;
    case Input::Sample:
      reg.sample(in.t, in.index, in.counters, out);
      break;
    case Input::Tick:
      reg.tick(in.t, out);
      break;
  }
}

Regulator make_regulator(const Setup& s) {
  MetricSpec metric;
  metric.counter_bits = s.counter_bits;
  return Regulator(RegulatorConfig{s.rt_count, accounts_for_scope(s.scope, s.entities), metric},
                   make_policy(s.policy));
}

// Everything observable after a run, compared exactly (doubles included).
struct Observed {
  Commands commands;
  std::vector<std::optional<TimeNs>> next_ticks;
  std::vector<std::tuple<double, double, TimeNs, std::uint64_t, bool>> accounts;
  std::vector<std::tuple<NodeState, std::uint64_t, double>> entities;
  bool operator==(const Observed&) const = default;
};

void observe_end(const Regulator& reg, Observed& o) {
  for (const Account& a : reg.accounts())
    o.accounts.emplace_back(a.budget_bytes, a.used_bytes, a.window_start, a.window, a.throttled);
  for (std::size_t e = 0; e < reg.entity_count(); ++e)
    o.entities.emplace_back(reg.entity(e).state, reg.entity(e).throttles,
                            reg.entity(e).bytes_active);
}

std::string describe(const Setup& s, std::uint64_t seed) {
  return "seed " + std::to_string(seed) + ", policy " + s.policy + ", scope " +
         std::string(to_string(s.scope)) + ", " + std::to_string(s.entities) + " entities, " +
         std::to_string(s.rt_count) + " RT nodes, " + std::to_string(s.counter_bits) + "-bit";
}

}  // namespace

TEST_CASE("determinism: identical input sequences give identical outputs", "[regulator][random]") {
  std::mt19937_64 pick(20240601);
  for (int run = 0; run < 12; ++run) {
    const Setup setup = random_setup(pick);
    const std::uint64_t seed = pick();
    INFO(describe(setup, seed));

    // First run: a host reacting to the regulator; its inputs are recorded.
    std::vector<Input> script;
    Observed first;
    {
      Regulator reg = make_regulator(setup);
      Host host(setup, seed);
      for (int i = 0; i < 5000; ++i) {
        script.push_back(host.next(reg));
        apply(reg, script.back(), first.commands);
        first.next_ticks.push_back(reg.next_tick());
      }
      observe_end(reg, first);
    }
    // Second run: the recorded inputs replayed on a fresh regulator.
    Observed second;
    {
      Regulator reg = make_regulator(setup);
      for (const Input& in : script) {
        apply(reg, in, second.commands);
        second.next_ticks.push_back(reg.next_tick());
      }
      observe_end(reg, second);
    }
    CHECK(first.commands.size() == second.commands.size());
    CHECK(first.commands == second.commands);
    CHECK(first == second);
    if (setup.policy != "none") CHECK_FALSE(first.commands.empty());
  }
}

TEST_CASE("invariants hold over many random input sequences", "[regulator][random]") {
  std::mt19937_64 pick(7);
  std::size_t throttles_seen = 0, replenishes_seen = 0;
  for (int run = 0; run < 300; ++run) {
    const Setup setup = random_setup(pick);
    const std::uint64_t seed = pick();
    INFO(describe(setup, seed));
    Regulator reg = make_regulator(setup);
    Host host(setup, seed);
    const bool regulates = setup.policy != "none";
    const bool throttles = setup.policy == "interval" || setup.policy == "monolithic";
    const bool periodic = setup.policy == "interval" || setup.policy == "monitor";
    const auto members = accounts_for_scope(setup.scope, setup.entities);

    std::vector<NodeState> state(setup.entities, NodeState::Off);       // as commanded
    std::set<std::tuple<int, std::uint64_t, std::size_t>> thr_windows;  // activation, window, e
    int activation = 0;
    TimeNs activation_start = 0;
    Commands out;

    for (int i = 0; i < 400; ++i) {
      const Input in = host.next(reg);
      const bool was_active = reg.active();
      const std::size_t before = out.size();
      apply(reg, in, out);
      const bool starts = in.kind == Input::Start && !was_active;
      const bool ends = in.kind == Input::Finish && !reg.active();
      if (starts) {
        ++activation;
        activation_start = in.t;
      }

      // No commands while inactive, none at all without regulation.
      if (!was_active && !starts) REQUIRE(out.size() == before);
      if (!regulates) REQUIRE(out.empty());

      for (std::size_t k = before; k < out.size(); ++k) {
        const CommandOut& c = out[k];
        INFO("command " << Catch::StringMaker<CommandOut>::convert(c) << " at input " << i);
        REQUIRE(c.t == in.t);
        REQUIRE(c.entity < setup.entities);
        NodeState& s = state[c.entity];
        switch (c.command) {
          case Command::On:
            REQUIRE(starts);
            REQUIRE(s == NodeState::Off);
            s = NodeState::On;
            break;
          case Command::Off:
            REQUIRE(ends);
            REQUIRE(s != NodeState::Off);
            s = NodeState::Off;
            break;
          case Command::Thr:
            REQUIRE(throttles);
            REQUIRE(s == NodeState::On);  // never THR to an entity not ON
            REQUIRE(
                thr_windows.insert({activation, reg.accounts()[members[c.entity]].window, c.entity})
                    .second);  // at most one THR per entity and window
            s = NodeState::Thr;
            ++throttles_seen;
            break;
          case Command::Replenish:
            REQUIRE(setup.policy == "interval");
            REQUIRE(s == NodeState::Thr);  // never REPLENISH to an entity not throttled
            s = NodeState::On;
            ++replenishes_seen;
            break;
        }
      }

      for (std::size_t e = 0; e < setup.entities; ++e)
        REQUIRE(reg.entity(e).state == state[e]);
      if (!reg.active() || !regulates) {
        // After the last rt_finished every entity is OFF.
        for (std::size_t e = 0; e < setup.entities; ++e)
          REQUIRE(state[e] == NodeState::Off);
        REQUIRE_FALSE(reg.next_tick().has_value());
        continue;
      }

      if (periodic) {
        // The current window is the one that holds t, whatever boundaries were missed.
        REQUIRE(reg.next_tick().has_value());
        REQUIRE(*reg.next_tick() > in.t);
        for (const Account& a : reg.accounts()) {
          REQUIRE(a.window_start == activation_start + static_cast<TimeNs>(a.window) * kPeriod);
          REQUIRE(a.window_start <= in.t);
          REQUIRE(in.t < a.window_start + kPeriod);
          REQUIRE(*reg.next_tick() == a.window_start + kPeriod);
        }
      } else {
        REQUIRE_FALSE(reg.next_tick().has_value());
      }
      for (std::size_t a = 0; a < reg.accounts().size(); ++a) {
        const Account& acc = reg.accounts()[a];
        if (!throttles) {
          REQUIRE_FALSE(acc.throttled);
          continue;
        }
        // Over budget means throttled; a throttled account has every member throttled.
        if (acc.used_bytes > acc.budget_bytes) REQUIRE(acc.throttled);
        for (std::size_t e = 0; e < setup.entities; ++e)
          if (members[e] == a)
            REQUIRE(state[e] == (acc.throttled ? NodeState::Thr : NodeState::On));
      }
    }
  }
  // The sequences must actually exercise throttling and replenishment.
  CHECK(throttles_seen > 100);
  CHECK(replenishes_seen > 100);
}

// The ROSGuard regulator core: a deterministic state machine driven by the host.
//
// Contract:
// - The host (a SystemC process, or the controller thread of the hw backend) calls every method
//   from one thread, with non-decreasing timestamps `t` (integer ns). The regulator never reads
//   a clock or a counter itself. A call rejected for its arguments changes nothing.
// - Commands are appended to the caller's `out` vector (never cleared here); reusing one vector
//   keeps sample() free of allocation.
// - Entities are the regulated nRT nodes, numbered 0..n-1. Each maps to a budget account (the
//   scope): one account per entity for scope core / node, one shared account for scope group.
// - The first sample of an entity after an activation starts is its baseline (no usage); the
//   host takes it as soon as the entity is switched ON. Later samples are cumulative readings of
//   the same counter group; their increase is the entity's usage.
// - Usage is charged to the window in which it occurred, as MemGuard does: a sample's increase
//   is spread evenly over the time between the entity's two readings (their measurement times),
//   and only the part after the window opened is charged to it. Traffic of a closed window
//   (e.g. the overshoot during the activation delay, measured by the first sample after
//   REPLENISH) is not carried into the next one: every window starts fresh.
// - Boundaries are processed before any input at or after them, so the order in which the host
//   calls tick() and sample() for the same t does not matter.
// - After usage is charged the policy judges it (Policy::judge): keep going, throttle the
//   account's entities, throttle every entity (a global cap), or release every throttled entity
//   (MemGuard's sharing). The global account (cap, pool of donated budget) is the regulator's,
//   opened with the accounts at every window.
// - Overflow sampling (MemGuard): overflow_limits() says at which cumulative counter values an
//   entity's interrupt must fire; the host arms its PMU with them after every input, and takes
//   the interrupt's reading to sample().
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "core/types.h"
#include "metric/metric.h"
#include "node/nrt_node.h"
#include "policy/policy.h"

namespace rosguard {

struct CommandOut {
  TimeNs t;
  std::size_t entity;
  Command command;
  bool operator==(const CommandOut&) const = default;
};

using Commands = std::vector<CommandOut>;

// Where an entity's overflow interrupt must fire: when sum_i(bytes_per_count[i] x counter_i),
// over its cumulative raw counter values in the metric's event order, exceeds at_bytes (no wrap
// and no multiplexing scaling: an overflow-armed PMU counts every event all the time, and the
// host re-arms before a counter could wrap). One per budgeted
// quantity (the total over the metric's events, or each event with a budget of its own).
struct OverflowLimit {
  std::vector<double> bytes_per_count;
  double at_bytes = 0.0;
  bool operator==(const OverflowLimit&) const = default;
};

// How a host whose overflow counters each count one event (perf_event_open: one sample_period
// per event) arms them for `limits`, from the entity's cumulative raw counter values `counts`
// now (in the metric's event order). A limit's bytes still left are split among the events it
// weighs, shares that add up to what is left, so that whichever counter overflows first does so
// at or before the limit's crossing; the host then reads the entity, samples it and arms again
// with what is left. The split follows each event's bytes since `previous` (the counts when the
// entity was last armed; empty: none), every event keeping at least kQuietOverflowShare of an
// even share: an event that was quiet and starts counting overflows early, and the next arm
// follows the new rates. Without a previous arm, or with no bytes since, the split is even. (An
// even split spends only half of what is left per signal where one of two events is quiet, as
// l2d_cache_wb is for a read-only workload: some 14 signals per throttle on the hw backend.)
inline constexpr double kQuietOverflowShare = 0.125;
struct OverflowArm {
  bool due = false;  // a limit is exceeded already: read the entity now, arm nothing
  // Per event: counts until its counter must overflow (>= 1), the smallest over the limits;
  // 0: no limit weighs this event (leave its counter disarmed).
  std::vector<std::uint64_t> periods;
  bool operator==(const OverflowArm&) const = default;
};
OverflowArm overflow_arm(std::span<const OverflowLimit> limits,
                         std::span<const CounterValue> counts,
                         std::span<const std::uint64_t> previous = {});

struct RegulatorConfig {
  std::size_t rt_count = 1;
  // account_of_entity[e] is the budget account of entity e; its size is the number of entities.
  std::vector<std::size_t> account_of_entity;
  MetricSpec metric;
};

// Entity -> account mapping for a scope: one account each for core and node scope (at most one
// application node per core), one shared account for group scope.
std::vector<std::size_t> accounts_for_scope(Scope scope, std::size_t entities);

// What the regulator knows of one entity, for tracing and tests.
struct EntityView {
  NodeState state = NodeState::Off;  // as last commanded
  std::size_t account = 0;
  std::uint64_t throttles = 0;  // THR commands sent since construction
  double bytes_active = 0.0;    // usage accounted since the activation began
};

class Regulator {
 public:
  Regulator(RegulatorConfig config, std::unique_ptr<Policy> policy);

  // An RT node's enable signal. The first running RT node starts an activation: windows open
  // and every entity gets ON.
  void rt_started(TimeNs t, std::size_t rt, Commands& out);
  // An RT node's disable signal. When the last running RT node finishes, every entity gets OFF.
  void rt_finished(TimeNs t, std::size_t rt, Commands& out);
  // Cumulative counter values of one entity, in the metric's event order, processed at `t` and
  // read at `measured_at` (default: t). Per entity, measurement times must not decrease and a
  // reading cannot be measured after it is processed.
  void sample(TimeNs t, std::size_t entity, std::span<const CounterValue> counters, Commands& out,
              std::optional<TimeNs> measured_at = std::nullopt);
  // Timer expiry the regulator asked for through next_tick().
  void tick(TimeNs t, Commands& out);

  // Replaces the policy between two inputs (a reconfiguration, e.g. `rosguard guard` on SIGHUP):
  // the window open now keeps its budget and boundary; every window after it opens under the new
  // policy, so regulation never pauses. Throws ContractError when the new policy does not
  // regulate exactly when the old one did (that would change what was sent to the entities).
  void set_policy(std::unique_ptr<Policy> policy);

  // When the host must call tick() next: the next window boundary while active, else nullopt.
  std::optional<TimeNs> next_tick() const;
  // Overflow sampling: the limits of an entity that is ON with a baseline while active (its
  // account's remaining budget from the entity's last reading); empty otherwise (nothing to arm:
  // inactive, throttled, released, or not yet read). With several entities on one account each
  // gets the account's whole remainder (scope group is refused for overflow sampling).
  std::vector<OverflowLimit> overflow_limits(std::size_t entity) const;

  bool active() const { return running_rt_ > 0; }
  const Policy& policy() const { return *policy_; }
  const Metric& metric() const { return metric_; }
  std::span<const Account> accounts() const { return accounts_; }
  const GlobalAccount& global() const { return global_; }
  const EntityView& entity(std::size_t e) const { return entities_.at(e).view; }
  std::size_t entity_count() const { return entities_.size(); }

 private:
  struct Entity {
    EntityView view;
    bool has_baseline = false;
    TimeNs last_measured = 0;
    std::vector<CounterValue> last;
  };

  void advance(TimeNs t, Commands& out);  // processes every boundary <= t
  void send(TimeNs t, std::size_t entity, Command c, Commands& out);
  void check_time(TimeNs t);
  void open_period(TimeNs start, bool fresh);
  void apply(Verdict v, TimeNs t, std::size_t account, Commands& out);

  Metric metric_;
  std::unique_ptr<Policy> policy_;
  std::vector<Entity> entities_;
  std::vector<Account> accounts_;
  GlobalAccount global_;
  std::vector<double> event_scratch_;
  std::vector<std::vector<std::size_t>> members_;  // account -> entities
  std::vector<bool> rt_running_;
  std::size_t running_rt_ = 0;
  std::optional<TimeNs> next_boundary_;
  TimeNs now_ = 0;
};

}  // namespace rosguard

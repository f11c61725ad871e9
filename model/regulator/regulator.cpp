#include "regulator/regulator.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/error.h"

namespace rosguard {

std::vector<std::size_t> accounts_for_scope(Scope scope, std::size_t entities) {
  std::vector<std::size_t> accounts(entities, 0);
  if (scope != Scope::Group)
    for (std::size_t e = 0; e < entities; ++e)
      accounts[e] = e;
  return accounts;
}

OverflowArm overflow_arm(std::span<const OverflowLimit> limits,
                         std::span<const CounterValue> counts,
                         std::span<const std::uint64_t> previous) {
  OverflowArm arm;
  arm.periods.assign(counts.size(), 0);
  // Far beyond any budget a window can hold, and below the 63 bits perf's period takes.
  constexpr double kMaxPeriod = 0x1p62;
  for (const OverflowLimit& l : limits) {
    if (l.bytes_per_count.size() > counts.size())
      throw ContractError("an overflow limit weighs more events than were counted");
    double now = 0.0, recent_sum = 0.0;
    std::size_t weighed = 0;
    std::vector<double> recent(l.bytes_per_count.size(), 0.0);  // bytes since `previous`
    for (std::size_t i = 0; i < l.bytes_per_count.size(); ++i) {
      now += l.bytes_per_count[i] * static_cast<double>(counts[i].value);
      if (l.bytes_per_count[i] <= 0.0) continue;
      ++weighed;
      if (i < previous.size() && counts[i].value > previous[i])
        recent[i] = l.bytes_per_count[i] * static_cast<double>(counts[i].value - previous[i]);
      recent_sum += recent[i];
    }
    if (weighed == 0) continue;
    if (now > l.at_bytes) {
      arm.due = true;
      continue;
    }
    const double left = l.at_bytes - now, even = 1.0 / static_cast<double>(weighed);
    for (std::size_t i = 0; i < l.bytes_per_count.size(); ++i) {
      if (l.bytes_per_count[i] <= 0.0) continue;
      const double fraction =
          recent_sum > 0.0
              ? kQuietOverflowShare * even + (1.0 - kQuietOverflowShare) * recent[i] / recent_sum
              : even;
      // Overflowing after p counts: strictly past the share (the limit fires on exceeding).
      const double p =
          std::min(kMaxPeriod, std::floor(left * fraction / l.bytes_per_count[i]) + 1.0);
      const auto period = static_cast<std::uint64_t>(p);
      if (arm.periods[i] == 0 || period < arm.periods[i]) arm.periods[i] = period;
    }
  }
  if (arm.due) std::fill(arm.periods.begin(), arm.periods.end(), 0);
  return arm;
}

void Regulator::set_policy(std::unique_ptr<Policy> policy) {
  if (!policy) throw ContractError("regulator needs a policy");
  if (policy->regulates() != policy_->regulates())
    throw ContractError("set_policy: '" + std::string(policy->name()) + "' and '" +
                        std::string(policy_->name()) + "' differ in whether they regulate");
  policy_ = std::move(policy);
}

Regulator::Regulator(RegulatorConfig config, std::unique_ptr<Policy> policy)
    : metric_(std::move(config.metric)),
      policy_(std::move(policy)),
      rt_running_(config.rt_count, false) {
  if (!policy_) throw ContractError("regulator needs a policy");
  std::size_t account_count = 0;
  for (std::size_t a : config.account_of_entity)
    account_count = std::max(account_count, a + 1);
  accounts_.resize(account_count);
  members_.resize(account_count);
  entities_.resize(config.account_of_entity.size());
  for (std::size_t e = 0; e < entities_.size(); ++e) {
    const std::size_t a = config.account_of_entity[e];
    entities_[e].view.account = a;
    entities_[e].last.resize(metric_.event_count());
    members_[a].push_back(e);
  }
  for (std::size_t a = 0; a < account_count; ++a)
    if (members_[a].empty()) throw ContractError("account " + std::to_string(a) + " has no entity");
}

void Regulator::check_time(TimeNs t) {
  if (t < now_)
    throw ContractError("regulator input at t=" + std::to_string(t) +
                        " ns is earlier than the previous one at " + std::to_string(now_));
  now_ = t;
}

void Regulator::send(TimeNs t, std::size_t entity, Command c, Commands& out) {
  EntityView& v = entities_[entity].view;
  switch (c) {
    case Command::On:
    case Command::Replenish:
      v.state = NodeState::On;
      break;
    case Command::Off:
      v.state = NodeState::Off;
      break;
    case Command::Thr:
      v.state = NodeState::Thr;
      ++v.throttles;
      break;
  }
  out.push_back({t, entity, c});
}

void Regulator::rt_started(TimeNs t, std::size_t rt, Commands& out) {
  if (rt >= rt_running_.size()) throw ContractError("no RT node " + std::to_string(rt));
  if (rt_running_[rt]) throw ContractError("RT node " + std::to_string(rt) + " started twice");
  check_time(t);
  advance(t, out);
  rt_running_[rt] = true;
  if (++running_rt_ > 1 || !policy_->regulates()) return;

  open_period(t, true);
  for (Account& a : accounts_)
    a.window = 0;
  next_boundary_ = policy_->window_end(t);
  for (std::size_t e = 0; e < entities_.size(); ++e) {
    entities_[e].has_baseline = false;
    entities_[e].view.bytes_active = 0.0;
    send(t, e, Command::On, out);
  }
}

void Regulator::rt_finished(TimeNs t, std::size_t rt, Commands& out) {
  if (rt >= rt_running_.size()) throw ContractError("no RT node " + std::to_string(rt));
  if (!rt_running_[rt]) throw ContractError("RT node " + std::to_string(rt) + " not running");
  check_time(t);
  rt_running_[rt] = false;
  // The last finish ends the activation: OFF alone, no REPLENISH of a boundary at the same t.
  if (--running_rt_ > 0) advance(t, out);
  if (running_rt_ > 0 || !policy_->regulates()) return;

  next_boundary_.reset();
  for (std::size_t e = 0; e < entities_.size(); ++e)
    send(t, e, Command::Off, out);
}

void Regulator::tick(TimeNs t, Commands& out) {
  check_time(t);
  advance(t, out);
}

std::optional<TimeNs> Regulator::next_tick() const {
  return next_boundary_;
}

void Regulator::advance(TimeNs t, Commands& out) {
  if (!next_boundary_ || t < *next_boundary_) return;
  // Catch up on every boundary passed: the window that holds t is the one that counts.
  TimeNs start = *next_boundary_;
  std::uint64_t windows = 1;
  for (auto end = policy_->window_end(start); end && *end <= t; end = policy_->window_end(start)) {
    start = *end;
    ++windows;
  }
  const std::uint64_t index = accounts_.empty() ? 0 : accounts_.front().window + windows;
  // Boundaries skipped over saw no input: the predictor (MemGuard) learns from the last window
  // only, as the module's timer does after an overrun.
  open_period(start, false);
  for (Account& a : accounts_)
    a.window = index;
  next_boundary_ = policy_->window_end(start);
  for (std::size_t e = 0; e < entities_.size(); ++e)
    if (entities_[e].view.state == NodeState::Thr) send(t, e, Command::Replenish, out);
}

void Regulator::open_period(TimeNs start, bool fresh) {
  policy_->open_period(start, accounts_, global_, fresh);
  const std::size_t events = metric_.event_count();
  for (Account& a : accounts_)
    if (!a.event_budget_bytes.empty() &&
        (a.event_budget_bytes.size() != events || a.event_used_bytes.size() != events))
      throw ContractError("policy '" + std::string(policy_->name()) + "' opened " +
                          std::to_string(a.event_budget_bytes.size()) +
                          " per-event budgets; the metric has " + std::to_string(events) +
                          " events");
}

void Regulator::apply(Verdict v, TimeNs t, std::size_t account, Commands& out) {
  switch (v) {
    case Verdict::Keep:
      return;
    case Verdict::ThrottleAccount:
      accounts_[account].throttled = true;
      for (std::size_t member : members_[account])
        if (entities_[member].view.state == NodeState::On) send(t, member, Command::Thr, out);
      return;
    case Verdict::ThrottleAll:
      for (Account& a : accounts_)
        a.throttled = true;
      for (std::size_t e = 0; e < entities_.size(); ++e)
        if (entities_[e].view.state == NodeState::On) send(t, e, Command::Thr, out);
      return;
    case Verdict::ReleaseAll:
      for (Account& a : accounts_)
        a.throttled = false;
      for (std::size_t e = 0; e < entities_.size(); ++e)
        if (entities_[e].view.state == NodeState::Thr) send(t, e, Command::Replenish, out);
      return;
  }
}

std::vector<OverflowLimit> Regulator::overflow_limits(std::size_t entity) const {
  if (entity >= entities_.size()) throw ContractError("no entity " + std::to_string(entity));
  std::vector<OverflowLimit> out;
  const Entity& ent = entities_[entity];
  if (!active() || !policy_->regulates() || !ent.has_baseline || ent.view.state != NodeState::On ||
      global_.released || global_.capped)
    return out;
  const Account& acc = accounts_[ent.view.account];
  if (acc.throttled) return out;
  const MetricSpec& m = metric_.spec();
  const auto at = [&](const std::vector<double>& per_count, double left) {
    double now = 0.0;
    for (std::size_t i = 0; i < per_count.size(); ++i)
      now += per_count[i] * static_cast<double>(ent.last[i].value);
    return OverflowLimit{per_count, now + std::max(0.0, left)};
  };
  if (std::isfinite(acc.budget_bytes)) {
    std::vector<double> per_count;
    for (const MetricEvent& e : m.events)
      per_count.push_back(e.weight * m.line_bytes);
    out.push_back(at(per_count, acc.budget_bytes - acc.used_bytes));
  }
  for (std::size_t i = 0; i < acc.event_budget_bytes.size(); ++i) {
    if (!std::isfinite(acc.event_budget_bytes[i])) continue;
    std::vector<double> per_count(m.events.size(), 0.0);
    per_count[i] = m.events[i].weight * m.line_bytes;
    out.push_back(at(per_count, acc.event_budget_bytes[i] - acc.event_used_bytes[i]));
  }
  return out;
}

void Regulator::sample(TimeNs t, std::size_t entity, std::span<const CounterValue> counters,
                       Commands& out, std::optional<TimeNs> measured_at) {
  if (entity >= entities_.size()) throw ContractError("no entity " + std::to_string(entity));
  Entity& ent = entities_[entity];
  if (counters.size() != ent.last.size())
    throw ContractError("sample has " + std::to_string(counters.size()) +
                        " counters, the metric has " + std::to_string(ent.last.size()));
  const TimeNs measured = measured_at.value_or(t);
  if (measured > t)
    throw ContractError("sample measured at t=" + std::to_string(measured) +
                        " ns, after it is processed at " + std::to_string(t));
  if (ent.has_baseline && active() && measured < ent.last_measured)
    throw ContractError("sample of entity " + std::to_string(entity) +
                        " measured at t=" + std::to_string(measured) +
                        " ns, before its previous reading at " + std::to_string(ent.last_measured));
  check_time(t);
  if (!active() || !policy_->regulates()) return;
  advance(t, out);

  if (ent.has_baseline) {
    const double bytes = metric_.delta_bytes(ent.last, counters);
    ent.view.bytes_active += bytes;
    Account& acc = accounts_[ent.view.account];
    // Charged to the window it occurred in: spread evenly between the two readings, only the
    // part after the window opened counts (every window starts fresh).
    double charged = bytes;
    if (ent.last_measured < acc.window_start)
      charged = measured <= acc.window_start
                    ? 0.0
                    : bytes * static_cast<double>(measured - acc.window_start) /
                          static_cast<double>(measured - ent.last_measured);
    acc.used_bytes += charged;
    global_.used_bytes += charged;
    if (!acc.event_used_bytes.empty()) {
      event_scratch_.resize(ent.last.size());
      metric_.event_bytes(ent.last, counters, event_scratch_);
      const double share = bytes > 0.0 ? charged / bytes : 0.0;
      for (std::size_t i = 0; i < event_scratch_.size(); ++i)
        acc.event_used_bytes[i] += event_scratch_[i] * share;
    }
    if (!acc.throttled && !global_.capped)
      apply(policy_->judge(ent.view.account, accounts_, global_), t, ent.view.account, out);
  }
  std::copy(counters.begin(), counters.end(), ent.last.begin());
  ent.last_measured = measured;
  ent.has_baseline = true;
}

}  // namespace rosguard

#include "regulator/regulator.h"

#include <algorithm>
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

  policy_->open_window(t, accounts_);
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
  policy_->open_window(start, accounts_);
  for (Account& a : accounts_)
    a.window = index;
  next_boundary_ = policy_->window_end(start);
  for (std::size_t e = 0; e < entities_.size(); ++e)
    if (entities_[e].view.state == NodeState::Thr) send(t, e, Command::Replenish, out);
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
    if (!acc.throttled && policy_->over_budget(acc)) {
      acc.throttled = true;
      for (std::size_t member : members_[ent.view.account])
        if (entities_[member].view.state == NodeState::On) send(t, member, Command::Thr, out);
    }
  }
  std::copy(counters.begin(), counters.end(), ent.last.begin());
  ent.last_measured = measured;
  ent.has_baseline = true;
}

}  // namespace rosguard

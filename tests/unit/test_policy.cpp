// Policies on their own: budgets, windows, the over-budget rule, and the registry.
#include <catch2/catch.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/error.h"
#include "regulator_support.h"

using namespace rosguard;
using namespace rosguard::test;

TEST_CASE("policies: budgets, windows and what regulates", "[policy]") {
  // 20 % of 1000 MB/s: 1 048 576 B per 5 ms period; over a 12 ms RT isolation time
  // 0.2 x 1000 x 1048576 x 0.012 = 2 516 582.4 B.
  const PolicyParams p = params(ms(5), ms(12));
  std::vector<Account> accounts(2);
  accounts[0].used_bytes = 99;
  accounts[0].throttled = true;
  accounts[1].window_start = 7;

  SECTION("interval") {
    const auto pol = make_interval_policy(p);
    CHECK(pol->name() == "interval");
    CHECK(pol->regulates());
    pol->open_window(ms(3), accounts);
    for (const Account& a : accounts) {
      CHECK(a.budget_bytes == 1048576.0);
      CHECK(a.used_bytes == 0.0);
      CHECK(a.window_start == ms(3));
      CHECK_FALSE(a.throttled);
    }
    CHECK(pol->window_end(ms(3)) == ms(8));
  }
  SECTION("monolithic: the whole activation, budget over the RT isolation time") {
    const auto pol = make_monolithic_policy(p);
    CHECK(pol->name() == "monolithic");
    CHECK(pol->regulates());
    pol->open_window(ms(3), accounts);
    CHECK(accounts[0].budget_bytes == Approx(2516582.4).epsilon(1e-12));
    CHECK(accounts[0].used_bytes == 0.0);
    CHECK_FALSE(accounts[0].throttled);
    CHECK_FALSE(pol->window_end(ms(3)).has_value());
  }
  SECTION("monitor: periodic windows, never over budget") {
    const auto pol = make_monitor_policy(p);
    CHECK(pol->name() == "monitor");
    CHECK(pol->regulates());
    pol->open_window(0, accounts);
    CHECK(accounts[1].budget_bytes == 1048576.0);
    CHECK(pol->window_end(ms(1)) == ms(6));
    Account a;
    a.budget_bytes = 1;
    a.used_bytes = 1e12;
    CHECK_FALSE(pol->over_budget(a));
  }
  SECTION("none: does not regulate") {
    const auto pol = make_none_policy(p);
    CHECK(pol->name() == "none");
    CHECK_FALSE(pol->regulates());
    CHECK_FALSE(pol->window_end(0).has_value());
  }
}

TEST_CASE("policies: over budget means strictly more than the budget", "[policy]") {
  for (const auto& pol : {make_interval_policy(params(ms(5), ms(12))),
                          make_monolithic_policy(params(ms(5), ms(12)))}) {
    INFO(pol->name());
    Account a;
    a.budget_bytes = 1000;
    a.used_bytes = 999;
    CHECK_FALSE(pol->over_budget(a));
    a.used_bytes = 1000;
    CHECK_FALSE(pol->over_budget(a));
    a.used_bytes = 1000.5;
    CHECK(pol->over_budget(a));
  }
}

TEST_CASE("policies: periodic policies reject a regulation period that is not positive",
          "[policy]") {
  // A zero period would make every window end where it starts: the regulator's catch-up loop
  // would never terminate.
  CHECK_THROWS_AS(make_interval_policy(params(0)), ContractError);
  CHECK_THROWS_AS(make_interval_policy(params(-ms(1))), ContractError);
  CHECK_THROWS_AS(make_monitor_policy(params(0)), ContractError);
  // Monolithic and none do not use the regulation period.
  CHECK_NOTHROW(make_monolithic_policy(params(0, ms(10))));
  CHECK_NOTHROW(make_none_policy(params(0)));
}

TEST_CASE("policies: monolithic rejects an RT execution window that is not positive", "[policy]") {
  // The window is the RT node's isolation time; a missing one must not become a zero budget.
  CHECK_THROWS_AS(make_monolithic_policy(params(ms(5), 0)), ContractError);
  CHECK_THROWS_AS(make_monolithic_policy(params(ms(5), -ms(1))), ContractError);
}

TEST_CASE("policy registry: built-ins by name, unknown names listed, no duplicates", "[policy]") {
  PolicyRegistry reg;
  register_builtin(reg);
  std::vector<std::string> names;
  for (const auto& info : reg.all()) {
    names.push_back(info.name);
    CHECK_FALSE(info.description.empty());
  }
  CHECK(names == std::vector<std::string>{"interval", "monolithic", "monitor", "none", "memguard",
                                          "mempol"});
  for (const auto& n : names) {
    REQUIRE(reg.find(n) != nullptr);
    CHECK(reg.make(n, params(ms(5), ms(10)))->name() == n);
  }
  CHECK(reg.find("adaptive") == nullptr);
  try {
    reg.make("adaptive", params());
    FAIL("unknown policy accepted");
  } catch (const InputError& e) {
    CHECK(e.json_path() == "/regulation/policy");
    CHECK(e.message() ==
          "unknown policy 'adaptive' (known: interval, monolithic, monitor, none, memguard, "
          "mempol)");
  }
  CHECK_THROWS_AS(reg.add({"interval", "again", {}, make_interval_policy}), ContractError);
  CHECK(reg.all().size() == 6);
}

TEST_CASE("policy traits: what each built-in policy is, without comparing names", "[policy]") {
  const auto traits = [](const char* name) {
    const PolicyInfo* p = find_builtin_policy(name);
    REQUIRE(p != nullptr);
    return p->traits;
  };
  CHECK(traits("interval").regulates);
  CHECK(traits("interval").throttles);
  CHECK(traits("interval").periodic_windows);
  CHECK_FALSE(traits("interval").needs_rt);
  CHECK_FALSE(traits("monolithic").periodic_windows);
  CHECK(traits("monolithic").needs_rt);
  CHECK(traits("monitor").regulates);
  CHECK_FALSE(traits("monitor").throttles);
  CHECK_FALSE(traits("none").regulates);
  CHECK(find_builtin_policy("adaptive") == nullptr);
  // The traits agree with what the policy objects do.
  for (const auto& info : builtin_policies()) {
    const auto policy = info.make(params(ms(5), ms(10)));
    CHECK(policy->regulates() == info.traits.regulates);
    if (info.traits.regulates)
      CHECK(policy->window_end(0).has_value() == info.traits.periodic_windows);
  }
}

// `rosguard list [KIND]`: what this rosguard knows of (workloads, platforms, policies,
// backends, pmc sources), how a throttled core can be held here, and the result columns.
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "commands/command.h"
#include "core/error.h"
#include "results/columns.h"

#ifdef ROSGUARD_WITH_HW
#include "hw/common/sys.h"
#include "hw/pmc_source/pmc_source.h"
#include "hw/throttle/throttle.h"
#endif

namespace rosguard {
namespace fs = std::filesystem;
namespace {

void print(const std::string& name, const std::string& text) {
  std::cout << "  " << std::left << std::setw(18) << name << text << "\n";
}

void list_workloads(const CommandContext& c) {
  std::cout << "workloads (" << c.loader.home().workloads().string() << "):\n";
  for (const auto& e : c.loader.workloads())
    print(e.name, e.summary);
}

void list_platforms(const CommandContext& c) {
  std::cout << "platforms (" << c.loader.home().platforms().string() << "):\n";
  for (const auto& e : c.loader.platforms())
    print(e.name, e.summary);
  std::string model;
  try {
    const fs::path path = host_model_path();
    std::error_code ec;
    model = path.string() + (fs::exists(path, ec) ? "" : ", not installed");
  } catch (const RunError& e) {
    model = e.what();
  }
  print(kHostPlatform,
        "(reserved) this machine: on hw probed when a scenario loads (rosguard platform "
        "probe shows it); on sim the installed calibrated model (" +
            model + ")");
}

void list_columns(const CommandContext&) {
  // Markdown, as docs/results.md's results section shows it (tools/columns_doc.py).
  std::cout << "| `points.csv` column | unit | meaning |\n|---|---|---|\n";
  for (const auto& c : point_column_dictionary())
    std::cout << "| `" << c.name << "` | " << c.unit << " | " << c.meaning << " |\n";
  std::cout << "\n| `samples.csv` kind | unit | meaning |\n|---|---|---|\n";
  for (const auto& c : sample_kind_dictionary())
    std::cout << "| `" << c.name << "` | " << c.unit << " | " << c.meaning << " |\n";
}

void list_policies(const CommandContext& c) {
  std::cout << "policies:\n";
  for (const auto& p : c.policies.all()) {
    std::string how;
    if (p.traits.regulates) {
      for (Sampling m : p.traits.samplings)
        how += (how.empty() ? " (sampling: " : ", ") + std::string(to_string(m));
      how += ")";
    }
    print(p.name, p.description + how);
  }
}

void list_backends(const CommandContext& c) {
  std::cout << "backends:\n";
  for (const auto& b : c.backends.all())
    print(b.name, b.description);
  if (c.backends.all().empty()) std::cout << "  (none built)\n";
}

void list_pmc_sources(const CommandContext&) {
  // The hw backend's counter sources, and whether each works on this host.
#ifdef ROSGUARD_WITH_HW
  hw::PmcSourceRegistry sources;
  hw::register_builtin(sources);
  std::cout << "pmc sources (hw backend; hw.pmc_source \"auto\" picks perf, else instrumented, "
               "else software):\n";
  for (const auto& info : sources.all()) {
    const auto src = info.make();
    const auto why = src->unavailable_reason();
    std::string events;
    for (const auto& e : src->events())
      events += (events.empty() ? "" : ", ") + e;
    print(info.name, info.description);
    print("", why ? "unavailable here: " + *why : "available here: " + events);
  }
#else
  std::cout << "pmc sources: (the hw backend is not built into this rosguard)\n";
#endif
}

void list_throttles(const CommandContext&) {
  // How a throttled nRT core can be held here, each measured (only when asked for: ~0.2 s each).
#ifdef ROSGUARD_WITH_HW
  const int core = hw::usable_cpus().back();
  std::cout << "throttles (hw.throttle; measured on CPU " << core
            << ": a worker's progress while throttled / nominal, 6 windows of 20 ms):\n";
  const auto fifo_err = hw::fifo_refused();
  std::string no_freezer;
  const bool freezer = hw::freezer_root(&no_freezer).has_value();
  for (const auto kind :
       {hw::ThrottleKind::Fifo, hw::ThrottleKind::Idle, hw::ThrottleKind::Freezer}) {
    const std::string name(hw::to_string(kind));
    if (kind == hw::ThrottleKind::Freezer && !freezer) {
      print(name, "unavailable here: " + no_freezer);
      continue;
    }
    const auto m = hw::measure_hold(kind, core);
    std::ostringstream line;
    if (std::isnan(m.hold_fraction))
      line << m.detail;
    else
      line << std::fixed << std::setprecision(3) << "hold " << 100.0 * m.hold_fraction
           << " % of nominal progress, activation " << std::setprecision(0) << m.activation_us
           << " us (worker CPU share unthrottled " << std::setprecision(2) << m.nominal_cpu_share
           << ")";
    if (kind == hw::ThrottleKind::Fifo && fifo_err)
      line << "; SCHED_FIFO refused (" << *fifo_err << "): THR ran at a nice value";
    print(name, line.str());
  }
#else
  std::cout << "throttles: (the hw backend is not built into this rosguard)\n";
#endif
}

struct Listing {
  const char* kind;
  void (*list)(const CommandContext&);
  bool in_all;  // part of a bare `rosguard list`
};

constexpr Listing kListings[] = {
    {"workloads", list_workloads, true},     {"platforms", list_platforms, true},
    {"policies", list_policies, true},       {"backends", list_backends, true},
    {"pmc-sources", list_pmc_sources, true}, {"throttles", list_throttles, false},
    {"columns", list_columns, false},
};

int list_catalogue(const CommandContext& c, const std::string& what) {
  if (what.empty()) {  // everything, one section after the other
    bool first = true;
    for (const Listing& l : kListings)
      if (l.in_all) {
        if (!first) std::cout << "\n";
        first = false;
        l.list(c);
      }
    return 0;
  }
  for (const Listing& l : kListings)
    if (what == l.kind) {
      l.list(c);
      return 0;
    }
  throw InputError("", "",
                   "cannot list '" + what +
                       "': choose workloads, platforms, policies, backends, pmc-sources, "
                       "throttles or columns");
}

}  // namespace

CommandHandler setup_list(CLI::App& sub) {
  auto kind = std::make_shared<std::string>();
  sub.add_option("kind", *kind,
                 "workloads | platforms | policies | backends | pmc-sources (default: all of "
                 "these) | throttles (measures each here) | columns")
      ->check(CLI::IsMember({"workloads", "platforms", "policies", "backends", "pmc-sources",
                             "throttles", "columns"}));
  return [kind](const CommandContext& c) { return list_catalogue(c, *kind); };
}

}  // namespace rosguard

#include "host/guard.h"

#include <malloc.h>
#include <signal.h>

#include <atomic>
#include <filesystem>
#include <iostream>

#include "core/error.h"
#include "load/loader.h"

#ifdef ROSGUARD_WITH_HW
#include "hw/common/clock.h"
#include "hw/guard/dds_guard.h"
#include "hw/guard/fifo_activity.h"
#include "hw/guard/guard.h"
#include "hw/topic/dds/cyclone_log.h"
#endif

namespace rosguard {

#ifdef ROSGUARD_WITH_HW
namespace {

std::atomic<int> g_stop{0};
std::atomic<bool> g_hup{false};

extern "C" void on_stop(int sig) {
  g_stop.store(sig);
}
extern "C" void on_hup(int) {
  g_hup.store(true);
}

// The file through the loader (Loader::load_guard: schema, defaults, the regulation's setup),
// the rest of it as typed settings.
hw::GuardSettings load_guard(const std::string& file, Loader& loader,
                             const PolicyRegistry& policies, nlohmann::json* out_doc = nullptr) {
  LoadedGuard loaded = loader.load_guard(file, policies);
  const std::string& shown = loaded.file;
  const nlohmann::json& doc = loaded.document;
  hw::GuardSettings s;
  s.file = shown;
  s.name = doc.at("name").get<std::string>();
  s.controller_core = doc.at("controller").at("core").get<int>();
  for (const auto& r : doc.at("rt"))
    s.rt.push_back(r.at("name").get<std::string>());
  for (std::size_t i = 0; i < s.rt.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (s.rt[i] == s.rt[j])
        throw InputError(shown, "/rt/" + std::to_string(i) + "/name",
                         "RT node '" + s.rt[i] + "' is listed twice");
  for (std::size_t i = 0; i < doc.at("nrt").size(); ++i) {
    const auto& n = doc.at("nrt")[i];
    hw::GuardSettings::Nrt nrt;
    nrt.core = n.at("core").get<int>();
    nrt.name = n.value("name", "core" + std::to_string(nrt.core));
    for (const auto& o : s.nrt)
      if (o.core == nrt.core || o.name == nrt.name)
        throw InputError(
            shown, "/nrt/" + std::to_string(i),
            "core " + std::to_string(nrt.core) + " ('" + nrt.name + "') is listed twice");
    if (nrt.core == s.controller_core)
      throw InputError(shown, "/nrt/" + std::to_string(i) + "/core",
                       "the controller's core cannot be regulated (its throttle would hold the "
                       "controller)");
    s.nrt.push_back(nrt);
  }
  s.regulation = std::move(loaded.regulation);
  const auto& h = doc.at("hw");
  const std::string src = h.at("pmc_source").get<std::string>();
  s.source = src == "perf"      ? hw::GuardSource::Perf
             : src == "cputime" ? hw::GuardSource::Cputime
                                : hw::GuardSource::Auto;
  s.throttle = parse_throttle_mode(h.at("throttle").get<std::string>());
  s.watchdog_ns = h.at("watchdog_ms").get<std::int64_t>() * kNsPerMs;
  s.rescan_ns = h.at("rescan_ms").get<std::int64_t>() * kNsPerMs;
  s.publish_every = doc.at("publish").at("every_n_samples").get<std::size_t>();
  s.max_active_ns = doc.at("activity").at("max_active_ms").get<std::int64_t>() * kNsPerMs;
  s.state_dir = doc.at("state_dir").get<std::string>();
  s.pin_processes = doc.value("pin_processes", std::vector<std::string>{});
  if (out_doc) *out_doc = doc;
  return s;
}

}  // namespace

int guard_command(const GuardArgs& args, Loader& loader, const PolicyRegistry& policies) {
  nlohmann::json doc;
  const hw::GuardSettings settings = load_guard(args.config, loader, policies, &doc);
  if (args.check) {
    std::cout << doc.dump(2) << "\n";
    // The file is valid; what this host lacks is said, not refused: the guard itself refuses it.
    for (const auto& [at, message] : hw::core_problems(settings))
      std::cerr << "warning: " << settings.file << ": " << at << ": " << message
                << ": the guard would refuse to start on this host\n";
    return 0;
  }
  // One malloc arena for all of the daemon's threads, set before any starts. glibc gives each
  // thread that meets a locked arena an arena of its own (up to 8 per core); memory freed into
  // one stays resident there, and the guard's RSS crept for as long as it ran
  // (tests/bench/guard_soak.sh, 30 min after the first: +1.48 % with the default arenas, +0.74 %
  // with one, on the 2-vCPU development VM).
  ::mallopt(M_ARENA_MAX, 1);
  const auto& act = doc.at("activity");
  const auto& dds_cfg = doc.at("dds");
  const std::optional<std::uint32_t> domain =
      dds_cfg.contains("domain_id") ? std::optional(dds_cfg.at("domain_id").get<std::uint32_t>())
                                    : std::nullopt;
  const std::string ns = dds_cfg.at("namespace").get<std::string>();
  std::optional<dds::Security> security;
  if (dds_cfg.contains("security")) {
    const auto& j = dds_cfg.at("security");
    // Relative paths are relative to the configuration file.
    const auto path = [&](const char* key) {
      const std::filesystem::path p = j.at(key).get<std::string>();
      return (p.is_absolute() ? p : std::filesystem::path(args.config).parent_path() / p).string();
    };
    security =
        dds::Security{path("identity_ca"),    path("identity_certificate"), path("private_key"),
                      path("permissions_ca"), path("governance"),           path("permissions")};
  }
  const dds::Security* sec = security ? &*security : nullptr;
  // Cyclone's own warnings (e.g. a line per malformed datagram anyone sends to its ports) through
  // the same rate limit as the guard's lines, before any DDS entity exists.
  // Every line the guard writes outside hw::Guard's own log, in its form: an ISO time stamp,
  // the guard's name, the text.
  const auto log_line = [name = settings.name](const std::string& text) {
    std::cerr << hw::wall_clock_iso() << " guard " << name << ": " << text << '\n' << std::flush;
  };
  const dds::LimitedCycloneLog cyclone_log(log_line, hw::kLogRepeatNs);
  // One DDS participant for the guard's activity readers and its publishers, announced to ROS 2
  // as the node <ns>/rosguard/guard_<name>.
  const bool dds_activity = act.at("source").get<std::string>() == "dds";
  const bool dds_publish = doc.at("publish").at("transport").get<std::string>() != "none";
  std::unique_ptr<dds::Participant> participant;
  if (dds_activity || dds_publish)
    participant = std::make_unique<dds::Participant>(
        domain, sec,
        dds::RosNode{dds::rosguard_node_namespace(ns),
                     dds::ros_node_name("guard_" + settings.name)});
  std::unique_ptr<hw::ActivitySource> activity;
  if (!dds_activity) {
    activity = std::make_unique<hw::FifoActivity>(
        act.at("path").get<std::string>(), [log_line](const std::string& line) {
          log_line("ignored activity line '" + line + "' (expected '<rt name> 1|0')");
        });
  } else {
    activity = std::make_unique<hw::DdsActivity>(*participant, ns, sec != nullptr);
  }
  std::unique_ptr<hw::GuardPublisher> publisher;
  if (!dds_publish) {
    publisher = std::make_unique<hw::NullPublisher>();
  } else {
    std::vector<std::string> cores;
    for (const auto& n : settings.nrt)
      cores.push_back(n.name);
    publisher = std::make_unique<hw::DdsPublisher>(*participant, cores, ns);
  }

  // Signals: SIGINT / SIGTERM stop, SIGHUP reloads; the handlers only set flags, which the main
  // loop looks at every pass (at most 50 ms apart).
  struct sigaction sa {};
  sa.sa_handler = on_stop;
  sigemptyset(&sa.sa_mask);
  struct sigaction old_int {
  }, old_term{}, old_hup{};
  ::sigaction(SIGINT, &sa, &old_int);
  ::sigaction(SIGTERM, &sa, &old_term);
  sa.sa_handler = on_hup;
  ::sigaction(SIGHUP, &sa, &old_hup);
  struct Restore {
    struct sigaction i, t, h;
    ~Restore() {
      ::sigaction(SIGINT, &i, nullptr);
      ::sigaction(SIGTERM, &t, nullptr);
      ::sigaction(SIGHUP, &h, nullptr);
    }
  } restore{old_int, old_term, old_hup};

  hw::Guard guard(settings, *activity, *publisher, std::cerr);
  guard.start();
  guard.run([] { return g_stop.load() != 0; }, [] { return g_hup.exchange(false); },
            [&]() -> std::optional<hw::GuardSettings> {
              try {
                return load_guard(args.config, loader, policies);
              } catch (const InputError& e) {
                log_line(std::string("reload refused: ") + e.what() +
                         "; the running configuration stays");
                return std::nullopt;
              }
            });
  log_line(std::string(g_stop.load() == SIGINT ? "SIGINT" : "SIGTERM") + " received");
  guard.shutdown();
  if (const auto n = cyclone_log.left_out())
    log_line("cyclone: " + std::to_string(cyclone_log.written()) + " log line(s) written, " +
             std::to_string(n) + " repeat(s) not logged");
  return 0;
}

#else

int guard_command(const GuardArgs&, Loader&, const PolicyRegistry&) {
  throw RunError(
      "this rosguard is built without the hw backend (ROSGUARD_WITH_HW=OFF): "
      "`rosguard guard` needs it");
}

#endif

}  // namespace rosguard

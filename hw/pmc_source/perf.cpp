// The perf source: hardware PMU events, and the perf_event_open group code the software source
// shares.
#include "hw/pmc_source/perf.h"

#include <linux/perf_event.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "core/error.h"
#include "hw/common/sys.h"

namespace rosguard::hw {
namespace {

long perf_event_open(perf_event_attr* attr, pid_t pid, int cpu, int group_fd, unsigned long flags) {
  long fd;
  do {
    fd = ::syscall(SYS_perf_event_open, attr, pid, cpu, group_fd, flags);
  } while (fd < 0 && errno == EINTR);
  return fd;
}

std::string code_text(const PerfEventCode& c) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "type %u config 0x%llx", c.type,
                static_cast<unsigned long long>(c.config));
  return buf;
}

std::string hint(int err) {
  switch (err) {
    case ENOENT:
    case EOPNOTSUPP:
      return ": this host does not provide the event (no hardware PMU, e.g. in a VM?)";
    case EACCES:
    case EPERM:
      return ": not permitted (kernel.perf_event_paranoid, or run as root)";
    case EINVAL:
      return ": invalid for this target or PMU";
    default:
      return "";
  }
}

class PerfGroup : public CounterGroup {
 public:
  PerfGroup(std::vector<Fd> fds, std::vector<std::string> names)
      : fds_(std::move(fds)), names_(std::move(names)), buf_(3 + fds_.size()) {}

  std::size_t size() const override { return fds_.size(); }

  void read(std::span<CounterValue> out) override {
    // PERF_FORMAT_GROUP layout: nr, time_enabled, time_running, value[nr].
    const std::size_t bytes = buf_.size() * sizeof(std::uint64_t);
    // A buffer per call, so that two threads may read the same group at once.
    std::uint64_t local[16];
    std::vector<std::uint64_t> big;
    if (buf_.size() > 16) big.resize(buf_.size());
    std::uint64_t* dst = buf_.size() <= 16 ? local : big.data();
    // ECHILD: an inherited child group is being torn down (its process is exiting) and the
    // kernel refuses to sum groups of different shapes (since Linux 6.6); it is gone a moment
    // later, so read again, a bounded number of times.
    ssize_t n;
    int child_retries = 1000;
    do {
      n = ::read(fds_[0].get(), dst, bytes);
    } while (n < 0 && (errno == EINTR || (errno == ECHILD && --child_retries > 0)));
    if (n != static_cast<ssize_t>(bytes))
      throw RunError("reading perf group (" + names_[0] + ", ...) failed: " +
                     (n < 0 ? errno_text(errno) : "short read of " + std::to_string(n) + " bytes"));
    const std::size_t k = std::min(out.size(), fds_.size());
    for (std::size_t i = 0; i < k; ++i)
      out[i] = {dst[3 + i], dst[1], dst[2]};
  }

 private:
  std::vector<Fd> fds_;
  std::vector<std::string> names_;
  std::vector<std::uint64_t> buf_;
};

class PerfSource : public PerfEventSource {
 public:
  std::string_view name() const override { return "perf"; }

  std::optional<std::string> unavailable_reason() const override { return probe("cpu_cycles"); }

  std::vector<std::string> events() const override {
    if (unavailable_reason()) return {};
    // A raw code the PMU does not implement opens but counts 0: not an event of this host.
    const auto implemented =
        host_arch() == Arch::Aarch64 ? armv8_pmu_events() : std::optional<Armv8PmuEvents>{};
    std::vector<std::string> out;
    for (const auto& n : hardware_event_names())
      if (const auto code = hardware_event(n, host_arch()); code && !pmu_lacks(*code, implemented))
        out.push_back(n);
    return out;
  }

 protected:
  std::vector<NamedEvent> named(const std::vector<std::string>& events) const override {
    std::vector<NamedEvent> out;
    for (const auto& e : events) {
      auto code = hardware_event(e, host_arch());
      if (!code)
        throw RunError("perf source: event '" + e + "' has no code on " +
                       std::string(to_string(host_arch())));
      out.emplace_back(e, *code);
    }
    return out;
  }
};

}  // namespace

std::optional<Armv8PmuEvents> armv8_pmu_events(const std::string& devices) {
  namespace fs = std::filesystem;
  std::optional<Armv8PmuEvents> out;
  std::error_code ec;
  std::vector<fs::path> pmus;
  for (const auto& d : fs::directory_iterator(devices, ec))
    if (d.path().filename().string().rfind("armv8_", 0) == 0 &&
        fs::is_directory(d.path() / "events"))
      pmus.push_back(d.path());
  std::sort(pmus.begin(), pmus.end());
  for (const auto& pmu : pmus) {
    std::set<std::uint64_t> codes;
    for (const auto& f : fs::directory_iterator(pmu / "events", ec)) {
      // "event=0x0017", possibly with more terms after a comma
      std::ifstream in(f.path());
      std::string text;
      std::getline(in, text);
      if (text.rfind("event=", 0) != 0) continue;
      try {
        codes.insert(std::stoull(text.substr(6), nullptr, 16));
      } catch (const std::exception&) {
      }
    }
    const std::string where = (pmu / "events").string();
    if (!out) {
      out = Armv8PmuEvents{std::move(codes), where};
      continue;
    }
    std::set<std::uint64_t> both;
    std::set_intersection(out->codes.begin(), out->codes.end(), codes.begin(), codes.end(),
                          std::inserter(both, both.end()));
    out->codes = std::move(both);
    out->where += " and " + where;
  }
  return out;
}

std::optional<std::string> pmu_lacks(const PerfEventCode& code,
                                     const std::optional<Armv8PmuEvents>& implemented) {
  if (!implemented || code.type != PERF_TYPE_RAW || code.config >= 0x40 ||
      implemented->codes.count(code.config))
    return std::nullopt;
  char hex[16];
  std::snprintf(hex, sizeof hex, "0x%02llx", static_cast<unsigned long long>(code.config));
  return "perf_event_open accepts the raw code " + std::string(hex) + " (" +
         std::string(code.note) + ") but the PMU does not implement it: not among the events " +
         "the kernel lists in " + implemented->where +
         " (its PMCEID registers), so it would count 0";
}

std::unique_ptr<CounterGroup> PerfEventSource::open(const std::vector<std::string>& events,
                                                    const PmcTarget& target) const {
  return open_perf_group(named(events), target);
}

std::optional<std::string> PerfEventSource::overflow_unavailable(
    const std::vector<std::string>& events) const {
  if (auto why = unavailable_reason()) return why;
  try {
    return probe_perf_overflow(named(events));
  } catch (const RunError& e) {
    return std::string(e.what());
  }
}

std::unique_ptr<OverflowCounters> PerfEventSource::open_overflow(
    const std::vector<std::string>& events, const PmcTarget& target) const {
  return open_perf_overflow(named(events), target);
}

std::unique_ptr<CounterGroup> open_perf_group(const std::vector<NamedEvent>& events,
                                              const PmcTarget& target) {
  if (events.empty()) throw RunError("perf group: no events to open");
  std::vector<Fd> fds;
  std::vector<std::string> names;
  pid_t pid = -1;
  int cpu = -1;
  switch (target.kind) {
    case PmcTarget::Kind::Thread:
      pid = target.pid;
      break;
    case PmcTarget::Kind::Process:
      pid = target.pid;
      break;
    case PmcTarget::Kind::Cpu:
      cpu = target.cpu;
      break;
  }
  bool exclude_kernel = false;
  for (std::size_t i = 0; i < events.size(); ++i) {
    const auto& [name, code] = events[i];
    perf_event_attr attr{};
    attr.size = sizeof attr;
    attr.type = code.type;
    attr.config = code.config;
    attr.read_format =
        PERF_FORMAT_GROUP | PERF_FORMAT_TOTAL_TIME_ENABLED | PERF_FORMAT_TOTAL_TIME_RUNNING;
    attr.exclude_hv = 1;
    attr.exclude_kernel = exclude_kernel ? 1 : 0;
    attr.inherit = target.kind == PmcTarget::Kind::Process ? 1 : 0;
    // Members follow the leader; the leader starts at once, or at exec for a fresh child.
    attr.disabled = (i == 0 && target.enable_on_exec) ? 1 : 0;
    attr.enable_on_exec = (i == 0 && target.enable_on_exec) ? 1 : 0;
    const int leader = fds.empty() ? -1 : fds[0].get();
    long fd = perf_event_open(&attr, pid, cpu, leader, PERF_FLAG_FD_CLOEXEC);
    if (fd < 0 && (errno == EACCES || errno == EPERM) && !exclude_kernel && i == 0) {
      // Unprivileged callers may count user space only: retry the whole group that way.
      exclude_kernel = true;
      attr.exclude_kernel = 1;
      fd = perf_event_open(&attr, pid, cpu, leader, PERF_FLAG_FD_CLOEXEC);
    }
    if (fd < 0) {
      const int err = errno;
      throw RunError("cannot open perf event '" + name + "' (" + code_text(code) + ") on " +
                     target.describe() + ": " + errno_text(err) + hint(err));
    }
    fds.emplace_back(static_cast<int>(fd));
    names.push_back(name);
  }
  return std::make_unique<PerfGroup>(std::move(fds), std::move(names));
}

std::unique_ptr<OverflowCounters> open_perf_overflow(const std::vector<NamedEvent>& events,
                                                     const PmcTarget& target) {
  if (target.kind != PmcTarget::Kind::Thread)
    throw ContractError("overflow counters count one thread, not " + target.describe());
  std::vector<Fd> fds;
  std::vector<std::string> names;
  std::vector<std::uint64_t> min_periods;
  for (const auto& [name, code] : events) {
    // The kernel runs its clock events on an hrtimer of at least 10 us (kernel/events/core.c,
    // perf_swevent_start_hrtimer).
    const bool clock = code.type == PERF_TYPE_SOFTWARE && (code.config == PERF_COUNT_SW_CPU_CLOCK ||
                                                           code.config == PERF_COUNT_SW_TASK_CLOCK);
    min_periods.push_back(clock ? 10'000 : 1);
    perf_event_attr attr{};
    attr.size = sizeof attr;
    attr.type = code.type;
    attr.config = code.config;
    // A sampling event (the period is set when armed); no ring buffer: only the signal is used.
    attr.sample_period = std::uint64_t{1} << 62;
    attr.disabled = 1;
    attr.exclude_hv = 1;
    long fd = perf_event_open(&attr, target.pid, -1, -1, PERF_FLAG_FD_CLOEXEC);
    if (fd < 0 && (errno == EACCES || errno == EPERM)) {
      attr.exclude_kernel = 1;  // unprivileged: user space only, as the groups do
      fd = perf_event_open(&attr, target.pid, -1, -1, PERF_FLAG_FD_CLOEXEC);
    }
    if (fd < 0) {
      const int err = errno;
      throw RunError("cannot open an overflow counter (sampling perf event '" + name + "', " +
                     code_text(code) + ") on " + target.describe() + ": " + errno_text(err) +
                     hint(err));
    }
    fds.emplace_back(static_cast<int>(fd));
    names.push_back(name);
  }
  return std::make_unique<PerfOverflowCounters>(std::move(fds), std::move(names),
                                                std::move(min_periods));
}

std::optional<std::string> probe_perf_overflow(const std::vector<NamedEvent>& events) {
  try {
    Waker waker;
    OverflowSink sink(1, waker);
    auto counters = open_perf_overflow(events, PmcTarget{});
    counters->claim(sink, 0);
    return std::nullopt;
  } catch (const RunError& e) {
    return std::string(e.what());
  }
}

std::unique_ptr<PmcSource> make_perf_source() {
  return std::make_unique<PerfSource>();
}

}  // namespace rosguard::hw

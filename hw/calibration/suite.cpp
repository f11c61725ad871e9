// The calibration microbenchmark suite (hw/calibration/suite.h).
#include "hw/calibration/suite.h"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <ctime>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <stdexcept>
#include <thread>
#include <tuple>

#include "core/error.h"
#include "engine/controller_driver.h"
#include "hw/common/clock.h"
#include "hw/common/sys.h"
#include "hw/executor/executor.h"
#include "hw/metric_plan.h"
#include "hw/nodes/messages.h"
#include "hw/pmc_source/pmc_source.h"
#include "hw/topic/dds_topic.h"
#include "hw/topic/topic.h"
#include "hw/workload/workload.h"
#include "policy/policy.h"
#include "regulator/regulator.h"
#include "results/results.h"

namespace rosguard::hw {
namespace {

using calibration::KernelRun;
using calibration::Measurements;

constexpr double kLineBytes = 64.0;
const char* const kBwRead = "bandwidth_read";
const char* const kBwWrite = "bandwidth_write";
const char* const kLatency = "latency";
// A window counts only if every kernel in it was on its core kMinOnCore of the time (clock.h);
// else it is taken again, at most kOnCoreAttempts times in all.
constexpr double kReferenceMbps = 10000.0;  // the synthetic controller's (any value works)

std::uint64_t lines_of(double kb) {
  return static_cast<std::uint64_t>(kb * 1024.0 / kLineBytes);
}

std::string kb_text(double kb) {
  return std::to_string(static_cast<long long>(kb)) + " KB";
}

// Notes for the manifest, each said once.
class Notes {
 public:
  void add(const std::string& s) {
    if (seen_.insert(s).second) list_.push_back(s);
  }
  void sched(const SchedOutcome& o) {
    if (!o.fifo)
      add("SCHED_FIFO refused (" + o.fifo_error +
          "): suite threads run under SCHED_OTHER with nice values instead; timings include "
          "more interference from other tasks");
    if (!o.pinned) add("a suite thread could not be pinned (" + o.pin_error + "): " + o.detail);
  }
  std::vector<std::string> take() { return std::move(list_); }

 private:
  std::set<std::string> seen_;
  std::vector<std::string> list_;
};

void rethrow_if_failed(const RtThread& t) {
  if (auto e = t.error()) std::rethrow_exception(e);
}

// A spinner on one core at an RT job's priority that records each gap in its own progress: the
// time another thread took that core. Used to see what a wake-up (a timer's, a callback's) costs
// the work it preempts (gaps_at).
class GapSpinner {
 public:
  GapSpinner(const std::string& name, int core, std::size_t capacity, Notes& notes)
      : gaps_(capacity) {
    // Settled when the spinner runs, or when its thread failed to start (on_error): the caller
    // blocks until then. It must block, not yield: above the spinner's priority on its core, a
    // yielding caller never lets it run (a run of the suite hung so on 2026-12-06).
    const auto settle = [this] {
      settled_.store(true, std::memory_order_release);
      settled_.notify_all();
    };
    thread_ = std::make_unique<RtThread>(
        ThreadSpec{name, core, SchedClass::Fifo, prio::kRt},
        [this, settle] {
          constexpr TimeNs kGapNs = 300;  // the loop itself takes ~20-40 ns
          TimeNs last = now_ns();
          settle();
          while (!stop_.load(std::memory_order_relaxed)) {
            const TimeNs now = now_ns();
            if (now - last > kGapNs) {
              const std::size_t k = count_.load(std::memory_order_relaxed);
              if (k < gaps_.size()) {
                gaps_[k] = {last, now};
                count_.store(k + 1, std::memory_order_release);
              }
            }
            last = now;
          }
        },
        [settle](const std::string&, std::exception_ptr) { settle(); });
    notes.sched(thread_->outcome());
    settled_.wait(false, std::memory_order_acquire);
  }
  ~GapSpinner() {
    stop_.store(true, std::memory_order_relaxed);
    if (thread_) thread_->join();
  }
  GapSpinner(const GapSpinner&) = delete;
  GapSpinner& operator=(const GapSpinner&) = delete;

  void stop() {
    stop_.store(true, std::memory_order_relaxed);
    thread_->join();
    rethrow_if_failed(*thread_);
  }
  // After stop(): the gaps seen, in time order.
  std::span<const SpinGap> gaps() const {
    return {gaps_.data(), count_.load(std::memory_order_acquire)};
  }

 private:
  std::vector<SpinGap> gaps_;
  std::atomic<std::size_t> count_{0};
  std::atomic<bool> stop_{false}, settled_{false};
  std::unique_ptr<RtThread> thread_;
};

// One built-in kernel over one working set, as the hw backend builds it (one pass per run).
std::unique_ptr<BuiltinWorkload> make_kernel(const std::string& kernel, double kb) {
  WorkloadInfo w;
  w.name = kernel;
  w.origin = "calibration suite";
  w.doc = {{"hw",
            {{"kernel", kernel}, {"working_set_kb", static_cast<std::size_t>(kb)}, {"passes", 1}}}};
  return make_builtin_workload(w);
}

// A kernel that runs pass after pass on one core until stopped; the engine reads its progress.
class Streamer {
 public:
  Streamer(BuiltinWorkload& work, double kb, int core, int priority, Notes& notes)
      : work_(work), lines_(lines_of(kb)) {
    thread_ = std::make_unique<RtThread>(
        ThreadSpec{"cal-" + std::to_string(core), core, SchedClass::Fifo, priority}, [this] {
          while (!stop_.load(std::memory_order_relaxed))
            work_.run(stop_, counters_);
        });
    notes.sched(thread_->outcome());
  }
  ~Streamer() {
    stop_.store(true, std::memory_order_relaxed);
    if (thread_) thread_->join();
  }
  Streamer(const Streamer&) = delete;
  Streamer& operator=(const Streamer&) = delete;

  void stop() {
    stop_.store(true, std::memory_order_relaxed);
    if (thread_) {
      thread_->join();
      rethrow_if_failed(*thread_);
      thread_.reset();
    }
  }
  std::uint64_t units() const { return counters_.units_done.load(std::memory_order_relaxed); }
  bool warm() const { return units() >= lines_; }  // one pass: its working set is in place
  pid_t tid() const { return thread_->tid(); }
  // CPU time the thread has run (ns), or -1 when the kernel will not say.
  TimeNs cpu_ns() const {
    // The per-thread CPU clock of thread `tid`, built as glibc's pthread_getcpuclockid does
    // (CPUCLOCK_SCHED | CPUCLOCK_PERTHREAD_MASK).
    const auto id = static_cast<clockid_t>((~static_cast<unsigned>(thread_->tid()) << 3) | 6u);
    timespec ts{};
    if (::clock_gettime(id, &ts) != 0) return -1;
    return static_cast<TimeNs>(ts.tv_sec) * kNsPerS + ts.tv_nsec;
  }
  const WorkCounters& counters() const { return counters_; }

 private:
  BuiltinWorkload& work_;
  std::uint64_t lines_;
  WorkCounters counters_;
  std::atomic<bool> stop_{false};
  std::unique_ptr<RtThread> thread_;
};

struct Corunner {
  std::string kernel;
  double kb = 0.0;
  auto key() const { return std::tie(kernel, kb); }
  bool operator<(const Corunner& o) const { return key() < o.key(); }
};

// A measured kernel with n co-runners of one kind on cores[1..n].
struct Config {
  std::string kernel;
  double kb = 0.0;
  int n = 0;
  auto key() const { return std::tie(kernel, kb, n); }
  bool operator<(const Config& o) const { return key() < o.key(); }
};

// One block of configurations measured with their rounds interleaved: the isolation block (no
// co-runner) or one co-runner kind.
struct Block {
  std::optional<Corunner> co;
  std::vector<Config> configs;
};

// The suite's kernel measurements, isolation first.
std::vector<Block> blocks_for(const SuiteShape& shape, int cores) {
  std::vector<Block> out;
  // Isolation: every kernel over every working set (the curve's and the matrix's included: their
  // zero-co-runner points).
  std::set<double> iso(shape.isolation_kb.begin(), shape.isolation_kb.end());
  iso.insert({shape.in_l3_kb, shape.dram_kb, shape.workload_kb});
  Block isolation;
  for (const char* k : {kBwRead, kBwWrite, kLatency})
    for (double kb : iso)
      isolation.configs.push_back({k, kb, 0});
  out.push_back(std::move(isolation));

  // Co-run blocks, one per co-runner kind: the bandwidth-latency curve (the shape's co-runner
  // counts) and the pair matrix (one co-runner).
  const int max_n = cores - 1;
  std::set<int> counts;
  for (int nco = 1; nco <= max_n; ++nco)
    if (shape.corunner_counts.empty() ||
        std::find(shape.corunner_counts.begin(), shape.corunner_counts.end(), nco) !=
            shape.corunner_counts.end())
      counts.insert(nco);
  std::map<Corunner, std::set<Config>> blocks;
  for (const char* ck : {kBwRead, kBwWrite})
    for (double ckb : {shape.dram_kb, shape.workload_kb}) {
      auto& b = blocks[{ck, ckb}];
      for (int nco : counts)
        for (const char* k : {kLatency, kBwRead, kBwWrite})
          for (double kb : {shape.in_l3_kb, shape.dram_kb})
            b.insert({k, kb, nco});
      if (max_n >= 1)
        for (const char* k : {kBwRead, kBwWrite})
          for (double kb : {shape.workload_kb, shape.dram_kb})
            b.insert({k, kb, 1});
    }
  for (auto& [co, configs] : blocks)
    if (!configs.empty()) out.push_back({co, std::vector<Config>(configs.begin(), configs.end())});
  return out;
}

int max_corunners(const Block& b) {
  int n = 0;
  for (const auto& c : b.configs)
    n = std::max(n, c.n);
  return n;
}

// The measured kernels the co-run blocks use (kept from the isolation block for them).
std::set<std::pair<std::string, double>> corun_measured(const std::vector<Block>& blocks) {
  std::set<std::pair<std::string, double>> out;
  for (const auto& b : blocks)
    if (b.co)
      for (const auto& c : b.configs)
        out.insert({c.kernel, c.kb});
  return out;
}

constexpr int kCostSteps = 8;  // the cost blocks, one progress step each

// The preemption cost's pairs of timed windows (Suite::preemptions): one pair per 50 cost samples,
// 4 to 60 (the quick suite 20, the full one 60), each window 5 measurement windows long (100 ms:
// some 330 wake-ups 300 us apart).
int preemption_pairs(const SuiteShape& shape) {
  return std::clamp(shape.cost_samples / 50, 4, 60);
}
double preemption_window_ms(const SuiteShape& shape) {
  return 5.0 * shape.window_ms;
}

std::string mb_text(double kb) {
  return std::to_string(static_cast<long long>(std::lround(kb / 1024.0))) + " MB";
}

std::string pct_text(double pct) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f %%", pct);
  return buf;
}

std::string iso_now() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  ::gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

class Suite {
 public:
  Suite(const SuiteOptions& o, const SuiteShape& shape, std::vector<int> cores)
      : opt_(o), shape_(shape), cores_(std::move(cores)) {}

  SuiteResult run();
  // The contention probe alone (measure_contention), on cores_[0] beside cores_[1].
  std::optional<calibration::ContentionProbe> contention_only();
  std::vector<std::string> take_notes() { return notes_.take(); }

 private:
  bool stopping() const { return opt_.stop && opt_.stop->load(std::memory_order_relaxed); }
  void step(const std::string& what) {
    ++step_;
    if (opt_.progress) opt_.progress(step_, steps_, what);
  }
  BuiltinWorkload& measured_kernel(const std::string& kernel, double kb);
  std::vector<std::unique_ptr<BuiltinWorkload>> build_corunners(const Corunner& co, int n);
  void build_measured(const std::vector<Config>& configs);
  void measure_block(const Block& block, const std::string& label);
  std::optional<calibration::ContentionProbe> probe_contention(const std::string& when);
  void measure_corun_block(const Block& block);
  bool wait_for_state(const std::string& co);
  std::optional<double> window(BuiltinWorkload& w, double kb,
                               const std::vector<std::unique_ptr<BuiltinWorkload>>& co_work,
                               double co_kb, int n);
  void record(const Config& c, const Corunner* co, const std::vector<double>& ns, int rounds);
  void measure_costs();
  void run_on(int core, int priority, const std::string& name, std::function<void()> body);
  std::unique_ptr<dds::Participant> message_transport();
  std::vector<double> timed_topic(
      dds::Participant* dds_participant, int nrt_core, int sub_core, const std::string& pub_name,
      const std::string& sub_name,
      const std::function<void(Topic<SampleMsg>&, std::size_t)>& publish_one);
  void message_costs(CounterGroup& group, const MetricPlan& plan, int nrt_core, int far_core,
                     dds::Participant* dds_participant);
  std::vector<double> cost_rounds(std::size_t n,
                                  const std::function<std::vector<double>(std::size_t)>& round);
  std::vector<double> throttle_activations(int nrt_core, int far_core, std::size_t count);
  std::vector<double> external_reads(CounterGroup& group, std::size_t group_size, int far_core);
  std::vector<double> controller_callbacks(const MetricPlan& plan, int feed_core, int ctl_core);
  std::vector<double> controller_callback_round(const MetricPlan& plan, int feed_core, int ctl_core,
                                                std::size_t count, std::size_t& unmatched,
                                                std::size_t& woken);
  std::vector<double> timer_wakeups(int core, std::size_t count, std::size_t& unmatched);
  std::vector<double> preemptions(int core, double wakeup_us);
  struct StreamWindow {
    double ns_per_line = 0.0;
    int wakeups = 0;
  };
  std::optional<StreamWindow> stream_window(BuiltinWorkload& w, double kb, int core, bool waker,
                                            double waker_share);
  void paced(const std::function<void(int, TimeNs)>& sample, int count);

  const SuiteOptions& opt_;
  const SuiteShape& shape_;
  std::vector<int> cores_;
  Notes notes_;
  Measurements m_;
  int step_ = 0, steps_ = 0;
  int retaken_ = 0, dropped_ = 0;       // windows where a kernel was off its core
  int precise_ = 0, capped_ = 0;        // measurements that reached the precision / the cap
  double widest_ = 0.0;                 // the widest CI (%) of those stopped at the cap
  std::vector<int> windows_;            // windows per measurement
  int blocks_retaken_ = 0;              // co-run blocks taken again: the DRAM interference changed
  std::vector<std::string> unsettled_;  // co-run blocks kept outside the suite's state
  double state_waited_s_ = 0.0;         // waiting for the suite's state before retakes
  int state_wait_probes_ = 0;           // probes that did not find it (not recorded)
  std::map<std::pair<std::string, double>, std::unique_ptr<BuiltinWorkload>> measured_;
};

BuiltinWorkload& Suite::measured_kernel(const std::string& kernel, double kb) {
  auto& w = measured_[{kernel, kb}];
  if (!w) w = make_kernel(kernel, kb);
  return *w;
}

// The measured kernels of `configs` not built yet, built (and their buffers first touched) on the
// measuring core, so that their pages are local to it.
void Suite::build_measured(const std::vector<Config>& configs) {
  std::vector<std::pair<std::string, double>> missing;
  for (const auto& c : configs)
    if (!measured_.count({c.kernel, c.kb})) missing.emplace_back(c.kernel, c.kb);
  if (missing.empty()) return;
  std::vector<std::unique_ptr<BuiltinWorkload>> built(missing.size());
  RtThread t(ThreadSpec{"cal-mk0", cores_[0], SchedClass::Other, prio::kNct}, [&] {
    for (std::size_t i = 0; i < missing.size() && !stopping(); ++i)
      built[i] = make_kernel(missing[i].first, missing[i].second);
  });
  t.join();
  notes_.sched(t.outcome());
  rethrow_if_failed(t);
  for (std::size_t i = 0; i < missing.size(); ++i)
    if (built[i]) measured_[missing[i]] = std::move(built[i]);
}

// The co-runners' kernels, one per co-runner core, each built on its core at once (first touch
// in parallel, pages local to the core that streams them).
std::vector<std::unique_ptr<BuiltinWorkload>> Suite::build_corunners(const Corunner& co, int n) {
  std::vector<std::unique_ptr<BuiltinWorkload>> work(static_cast<std::size_t>(n));
  std::vector<std::unique_ptr<RtThread>> builders;
  for (int i = 0; i < n; ++i)
    builders.push_back(std::make_unique<RtThread>(
        ThreadSpec{"cal-mk" + std::to_string(i + 1), cores_[static_cast<std::size_t>(i) + 1],
                   SchedClass::Other, prio::kNct},
        [&, i] { work[static_cast<std::size_t>(i)] = make_kernel(co.kernel, co.kb); }));
  for (auto& b : builders) {
    b->join();
    notes_.sched(b->outcome());
  }
  for (auto& b : builders)
    rethrow_if_failed(*b);
  return work;
}

// One timed window: the measured kernel and n co-runners stream, then the measured kernel's
// progress over window_ms gives ns per line. Empty when it made no progress (starved).
std::optional<double> Suite::window(BuiltinWorkload& w, double kb,
                                    const std::vector<std::unique_ptr<BuiltinWorkload>>& co_work,
                                    double co_kb, int n) {
  std::vector<std::unique_ptr<Streamer>> all;  // [0]: the measured kernel
  all.push_back(std::make_unique<Streamer>(w, kb, cores_[0], prio::kRt, notes_));
  for (int i = 0; i < n; ++i)
    all.push_back(std::make_unique<Streamer>(*co_work[static_cast<std::size_t>(i)], co_kb,
                                             cores_[static_cast<std::size_t>(i) + 1], prio::kNct,
                                             notes_));
  // Streaming: every kernel has done a pass (its working set is in place) or warmup_ms passed
  // (a pass over a DRAM working set can take longer; nothing more to warm there).
  const TimeNs warm_by = now_ns() + static_cast<TimeNs>(shape_.warmup_ms * 1e6);
  const auto all_warm = [&] {
    return std::all_of(all.begin(), all.end(), [](const auto& s) { return s->warm(); });
  };
  while (!all_warm() && now_ns() < warm_by)
    sleep_until(now_ns() + 200 * kNsPerUs);
  std::vector<TimeNs> cpu0;
  for (const auto& s : all)
    cpu0.push_back(s->cpu_ns());
  const TimeNs t0 = now_ns();
  const std::uint64_t u0 = all[0]->units();
  sleep_until(t0 + static_cast<TimeNs>(shape_.window_ms * 1e6));
  const std::uint64_t u1 = all[0]->units();
  const TimeNs t1 = now_ns();
  // How much of the window each kernel was on its core: SCHED_FIFO threads still lose the CPU to
  // RT throttling (sched_rt_runtime_us) and to higher priorities; under SCHED_OTHER to anything.
  double ran = 1.0;
  for (std::size_t i = 0; i < all.size(); ++i) {
    const TimeNs cpu1 = all[i]->cpu_ns();
    if (cpu0[i] >= 0 && cpu1 >= 0)
      ran = std::min(ran, static_cast<double>(cpu1 - cpu0[i]) / static_cast<double>(t1 - t0));
  }
  for (auto& s : all)
    s->stop();
  if (u1 <= u0 || ran < kMinOnCore) return std::nullopt;
  return static_cast<double>(t1 - t0) / static_cast<double>(u1 - u0);
}

void Suite::record(const Config& c, const Corunner* co, const std::vector<double>& ns, int rounds) {
  if (ns.empty()) return;
  KernelRun r;
  r.kernel = c.kernel;
  r.working_set_kb = c.kb;
  for (int i = 0; i < c.n; ++i)
    r.corunners.push_back({co->kernel, co->kb});
  r.ns_per_line = median(ns);
  r.cv = ns.size() < 2 ? 0.0 : coefficient_of_variation(ns);  // one window: no spread seen
  r.samples = static_cast<int>(ns.size());
  const double ci = median_ci95_pct(ns);
  if (std::isfinite(ci)) r.ci95_pct = ci;
  windows_.push_back(r.samples);
  if (ns.size() >= static_cast<std::size_t>(shape_.repetitions.min_windows) &&
      ci <= shape_.repetitions.precision_pct) {
    ++precise_;
  } else if (rounds >= shape_.repetitions.max_windows) {
    ++capped_;
    widest_ = std::max(widest_, ci);
  }
  m_.runs.push_back(std::move(r));
}

// Round r of every unfinished configuration before round r + 1 of any (drift hits all alike); a
// configuration is finished when repetitions_done() says so. The co-runners' buffers (one per
// co-runner core) live for the block.
void Suite::measure_block(const Block& block, const std::string& label) {
  const Corunner* co = block.co ? &*block.co : nullptr;
  const auto& configs = block.configs;
  const RepetitionRule& rule = shape_.repetitions;
  build_measured(configs);
  std::vector<std::unique_ptr<BuiltinWorkload>> co_work;
  if (co && !stopping()) co_work = build_corunners(*co, max_corunners(block));
  std::vector<std::vector<double>> ns(configs.size());
  std::vector<int> rounds(configs.size(), 0);
  std::vector<bool> done(configs.size(), false);
  for (bool any = true; any && !stopping();) {
    any = false;
    for (std::size_t i = 0; i < configs.size() && !stopping(); ++i) {
      if (done[i]) continue;
      any = true;
      const auto& c = configs[i];
      const double ci = median_ci95_pct(ns[i]);
      step(label + ": " + c.kernel + " " + kb_text(c.kb) +
           (c.n ? " with " + std::to_string(c.n) + "x " + co->kernel + " " + kb_text(co->kb) : "") +
           " (window " + std::to_string(rounds[i] + 1) +
           (std::isfinite(ci) ? ", +-" + pct_text(ci) : "") + ")");
      for (int attempt = 0; attempt < kOnCoreAttempts && !stopping(); ++attempt) {
        if (auto v =
                window(measured_kernel(c.kernel, c.kb), c.kb, co_work, co ? co->kb : 0.0, c.n)) {
          ns[i].push_back(*v);
          break;
        }
        ++(attempt + 1 < kOnCoreAttempts ? retaken_ : dropped_);
      }
      ++rounds[i];
      if (repetitions_done(ns[i], rounds[i], rule)) {
        done[i] = true;
        steps_ -= rule.max_windows - rounds[i];  // the rounds it will not take
      }
    }
  }
  for (std::size_t i = 0; i < configs.size(); ++i)
    record(configs[i], co, ns[i], rounds[i]);
}

// The contention probe (calibration::ContentionProbe): bandwidth_read over the DRAM set on
// cores_[0], a window alone and a window beside one on cores_[1] per round, kContentionRounds
// rounds with both windows kept (a round that lost one, a kernel off its CPU after
// kOnCoreAttempts, is taken again for up to kContentionPatienceS: on the Xeon VM of 2026-11-28
// the host took 5 % or more of a 20 ms window from a spinning vCPU in a third of the windows, in
// bursts of up to 4 s, under SCHED_FIFO or not); the ratio of each round's pair, so that drift
// between rounds cancels, and the median of the windows alone (the host's speed). Recorded in the
// measurements with `when`. Empty when stopped before a round completed; throws RunError when no
// round kept its windows.
std::optional<calibration::ContentionProbe> Suite::probe_contention(const std::string& when) {
  const double kb = shape_.dram_kb;
  step("contention probe: bandwidth_read " + kb_text(kb) + " alone and beside one on CPU " +
       std::to_string(cores_[1]) + (when.empty() ? "" : " (" + when + ")"));
  build_measured({{kBwRead, kb, 0}});
  // Its own co-runner buffer, built for the probe and freed after it (between co-run blocks, so
  // the buffers held at once stay within a DRAM block's).
  std::vector<std::unique_ptr<BuiltinWorkload>> co;
  if (!stopping()) co = build_corunners({kBwRead, kb}, 1);
  BuiltinWorkload& w = measured_kernel(kBwRead, kb);
  const auto timed = [&](int n) -> std::optional<double> {
    for (int attempt = 0; attempt < kOnCoreAttempts && !stopping(); ++attempt) {
      if (auto v = window(w, kb, co, kb, n)) return v;
      ++(attempt + 1 < kOnCoreAttempts ? retaken_ : dropped_);
    }
    return std::nullopt;
  };
  std::vector<double> ratios, alone_ns;
  const TimeNs patience = now_ns() + static_cast<TimeNs>(kContentionPatienceS * 1e9);
  int r = 0;
  for (; std::ssize(ratios) < kContentionRounds && (r < kContentionRounds || now_ns() < patience) &&
         !stopping();
       ++r) {
    const auto alone = timed(0);
    const auto beside = timed(1);
    if (alone && beside) {
      ratios.push_back(*beside / *alone);
      alone_ns.push_back(*alone);
    }
  }
  if (ratios.empty() && stopping()) return std::nullopt;
  if (ratios.empty())
    throw RunError("contention probe: in " + std::to_string(r) + " rounds over " +
                   std::to_string(static_cast<int>(kContentionPatienceS)) +
                   " s, no window of bandwidth_read " + kb_text(kb) + " on CPU " +
                   std::to_string(cores_[0]) + " (alone, then beside CPU " +
                   std::to_string(cores_[1]) + ") kept both kernels on their CPUs " +
                   std::to_string(std::lround(kMinOnCore * 100)) +
                   " % of the time: the host is taking the CPUs (a virtual machine's steal "
                   "time, other real-time work, or RT throttling); measure when it is quieter");
  calibration::ContentionProbe p;
  p.cores = {cores_[0], cores_[1]};
  p.working_set_kb = kb;
  p.ratio = median(ratios);
  if (const double ci = median_ci95_pct(ratios); std::isfinite(ci)) p.ci95_pct = ci;
  p.alone_ns_per_line = median(alone_ns);
  p.rounds = static_cast<int>(ratios.size());
  p.date = iso_now();
  p.when = when;
  m_.contention.push_back(p);
  return p;
}

// Before a retake of the co-runs beside `co`: probes until one finds the suite's state so far
// (calibration::suite_state: the one most co-runs were measured in, the model's), or until the
// suite has waited shape_.state_wait_s in all; the probe it stops at is recorded (the retake's
// before-probe), those before it are not (they would vote for the state being waited out) and only
// counted. Between probes the host may move the vCPUs back: on the EPYC VM of 2026-11-28 a state
// lasted seconds to minutes, and a block retaken at once met the same state three times (10:26, the
// DRAM reader pair at 0.99x in a suite at 1.54x). False when stopped.
bool Suite::wait_for_state(const std::string& co) {
  const auto state = calibration::suite_state(m_);
  const auto t0 = std::chrono::steady_clock::now();
  for (bool first = true;; first = false) {
    if (!first) ++steps_;  // a probe more than planned
    const auto p = probe_contention("before the co-runs beside " + co + ", again");
    if (!p) return false;
    const double waited =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!state || calibration::same_contention_state(*state, *p) ||
        state_waited_s_ + waited >= shape_.state_wait_s) {
      state_waited_s_ += waited;
      return true;
    }
    m_.contention.pop_back();
    ++state_wait_probes_;
  }
}

// A co-run block between two contention probes (the one before it is the previous block's
// after-probe; a retake's is taken afresh, after wait_for_state): taken again, up to
// kStateAttempts times in all, while a probe around it is in another state than the suite's so
// far (calibration::suite_state; the host moved the vCPUs under it), so that the co-run blocks are
// measured in one state; kept after the last attempt (unsettled_ says so).
void Suite::measure_corun_block(const Block& block) {
  const std::string co = block.co->kernel + " " + kb_text(block.co->kb);
  if (m_.contention.empty() && !probe_contention("before the co-runs")) return;
  for (int attempt = 1; !stopping(); ++attempt) {
    if (attempt > 1 && !wait_for_state(co)) return;
    const calibration::ContentionProbe before = m_.contention.back();
    const int before_at = static_cast<int>(m_.contention.size()) - 1;
    const std::size_t runs = m_.runs.size(), windows = windows_.size();
    const int precise = precise_, capped = capped_;
    const double widest = widest_;
    measure_block(block, "co-run");
    const auto after = probe_contention("after the co-runs beside " + co);
    if (!after) return;
    for (std::size_t i = runs; i < m_.runs.size(); ++i)
      m_.runs[i].probes = {before_at, static_cast<int>(m_.contention.size()) - 1};
    // The suite's state so far, the one its model will describe (not simply the first probe's:
    // the host may move the vCPUs right after it and keep them there).
    const auto state = calibration::suite_state(m_);
    if (calibration::same_contention_state(*state, before) &&
        calibration::same_contention_state(*state, *after))
      return;
    if (attempt == kStateAttempts) {
      unsettled_.push_back(co + " (" + calibration::describe(before) + " before, " +
                           calibration::describe(*after) + " after)");
      return;
    }
    m_.runs.resize(runs);
    windows_.resize(windows);
    precise_ = precise;
    capped_ = capped;
    widest_ = widest;
    ++blocks_retaken_;
    steps_ += static_cast<int>(block.configs.size()) * shape_.repetitions.max_windows + 2;
  }
}

std::optional<calibration::ContentionProbe> Suite::contention_only() {
  ScopedSched engine(ThreadSpec{"", -1, SchedClass::Fifo, prio::kEngine});
  notes_.sched(engine.outcome());
  steps_ = 1;
  return probe_contention("");
}

// Runs sample(i, due) for i < count on the calling thread, one every cost_spacing_us (an absolute
// schedule, but never less than cost_spacing_us after the previous sample), until done or stopped;
// `due` is the time its timer was set for.
void Suite::paced(const std::function<void(int, TimeNs)>& sample, int count) {
  const auto spacing = static_cast<TimeNs>(shape_.cost_spacing_us * 1e3);
  TimeNs next = now_ns() + spacing;
  for (int i = 0; i < count && !stopping(); ++i) {
    sleep_until(next);
    sample(i, next);
    // A full spacing after this sample even when the sleep overslept: with a quarter spacing the
    // next sample could meet the previous one's wake-up still running (a cross-core wake takes
    // 15-60 us on the development VM), and such samples are not timed. The tiny suite's test
    // (20 samples, 200 us apart) got fewer than half of them timed in 2 of 60 runs that way
    // (2026-11-28, Intel Xeon VM), in 0 of 40 with a full spacing.
    next = std::max(next + spacing, now_ns() + spacing);
  }
}

void Suite::run_on(int core, int priority, const std::string& name, std::function<void()> body) {
  RtThread t(ThreadSpec{name, core, SchedClass::Fifo, priority}, std::move(body));
  notes_.sched(t.outcome());
  t.join();
  rethrow_if_failed(t);
}

// The participant the message costs publish through: none for inproc topics, one of Cyclone DDS
// for dds (hw.transport dds).
std::unique_ptr<dds::Participant> Suite::message_transport() {
  std::unique_ptr<dds::Participant> dds_participant;
  if (opt_.transport == "dds") {
    dds_participant = std::make_unique<dds::Participant>(
        std::nullopt, nullptr, dds::RosNode{dds::rosguard_node_namespace(""), "calibrate"});
    notes_.add(
        "message costs (publish, message_latency, local_message_latency) over Cyclone DDS "
        "(hw.transport dds), domain " +
        std::to_string(dds_participant->domain_id()));
  } else if (opt_.transport != "inproc") {
    throw RunError("calibration suite: unknown transport '" + opt_.transport + "'");
  }
  return dds_participant;
}

// Paced messages published from the nRT core (`publish_one`, at the PMC thread's priority) on a
// topic (over `dds_participant` if any, else in-process) whose one subscriber (the controller's
// priority, threads named `pub_name` and `sub_name`) sleeps on `sub_core`: each message's publish
// -> subscriber awake, in us. The subscriber's core is busy meanwhile, as under regulation (an RT
// job or an nRT node runs on the controller's core): on the nRT core the NCT streams; on another
// core a spinner does, under SCHED_OTHER so that middleware threads (Cyclone's) still get that
// core. An idle destination measures something else: waking a halted CPU (under KVM, a vCPU the
// host descheduled), tens of us slower (25.4 against 9.4 us median on the development VM,
// 2026-11-26).
std::vector<double> Suite::timed_topic(
    dds::Participant* dds_participant, int nrt_core, int sub_core, const std::string& pub_name,
    const std::string& sub_name,
    const std::function<void(Topic<SampleMsg>&, std::size_t)>& publish_one) {
  const int n = shape_.cost_samples;
  std::atomic<bool> spin_done{false};
  std::optional<RtThread> spinner;
  if (sub_core != nrt_core) {
    spinner.emplace(ThreadSpec{"cal-busy", sub_core, SchedClass::Other, 0}, [&] {
      while (!spin_done.load(std::memory_order_relaxed)) {
      }
    });
    notes_.sched(spinner->outcome());
  }
  struct StopSpinner {
    std::atomic<bool>& done;
    std::optional<RtThread>& thread;
    ~StopSpinner() {
      done.store(true, std::memory_order_relaxed);
      if (thread) thread->join();
    }
  } stop_spinner{spin_done, spinner};
  std::unique_ptr<Topic<SampleMsg>> owned;
  if (dds_participant)
    owned = std::make_unique<DdsTopic<SampleMsg>>(
        *dds_participant, "/rosguard_calibrate_" + std::to_string(::getpid()),
        std::vector<DdsSlot>{{"cal", 0}});
  else
    owned = std::make_unique<InprocTopic<SampleMsg>>();
  Topic<SampleMsg>& topic = *owned;
  Waker sub_waker;
  const std::size_t pub = topic.add_publisher();
  const std::size_t sub = topic.subscribe(sub_waker);
  std::vector<double> latency;
  latency.reserve(static_cast<std::size_t>(n));
  std::atomic<bool> done{false};
  RtThread subscriber(ThreadSpec{sub_name, sub_core, SchedClass::Fifo, prio::kController}, [&] {
    while (!done.load(std::memory_order_acquire)) {
      const auto e = sub_waker.epoch();
      if (done.load(std::memory_order_acquire)) break;  // a stop notified before the epoch read
      SampleMsg m;
      bool got = false;
      while (topic.take(sub, m)) {
        latency.push_back(ns_to_us(now_ns() - m.t_published));
        got = true;
      }
      if (!got) sub_waker.wait(e, -1);
    }
  });
  notes_.sched(subscriber.outcome());
  run_on(nrt_core, prio::kPmc, pub_name,
         [&] { paced([&](int, TimeNs) { publish_one(topic, pub); }, n); });
  done.store(true, std::memory_order_release);
  sub_waker.notify();
  subscriber.join();
  rethrow_if_failed(subscriber);
  return latency;
}

// pmc_callback (the group read into a sample), publish (on the samples topic, subscriber asleep
// on another core) and message_latency (publish -> the subscriber awake); then
// local_message_latency: the same publish -> subscriber awake, with both on one core (the
// controller sharing the nRT core, as it must on 2 CPUs): the subscriber (the controller's
// priority) preempts the publisher (the PMC thread's) at once, no inter-processor wake-up.
void Suite::message_costs(CounterGroup& group, const MetricPlan& plan, int nrt_core, int far_core,
                          dds::Participant* dds_participant) {
  const int n = shape_.cost_samples;
  auto& costs = m_.costs_us;
  if (!stopping()) {
    step("costs: pmc_callback, publish, message_latency");
    const std::size_t group_size = plan.group_events.size();
    std::vector<double> cb, publish;
    cb.reserve(static_cast<std::size_t>(n));
    publish.reserve(static_cast<std::size_t>(n));
    costs["message_latency"] =
        timed_topic(dds_participant, nrt_core, far_core, "cal-pmc", "cal-sub",
                    [&](Topic<SampleMsg>& topic, std::size_t pub) {
                      SampleMsg msg;
                      msg.count = static_cast<std::uint8_t>(plan.metric_events);
                      const TimeNs t0 = now_ns();
                      group.read(std::span(msg.counters.data(), group_size));
                      const TimeNs t1 = now_ns();
                      msg.t_published = t1;
                      topic.publish(pub, msg);
                      const TimeNs t2 = now_ns();
                      cb.push_back(ns_to_us(t1 - t0));
                      publish.push_back(ns_to_us(t2 - t1));
                    });
    costs["pmc_callback"] = std::move(cb);
    costs["publish"] = std::move(publish);
  }
  if (!stopping()) {
    step("costs: local_message_latency");
    costs["local_message_latency"] =
        timed_topic(dds_participant, nrt_core, nrt_core, "cal-lpub", "cal-lsub",
                    [](Topic<SampleMsg>& topic, std::size_t pub) {
                      SampleMsg msg;
                      msg.t_published = now_ns();
                      topic.publish(pub, msg);
                    });
  }
}

// throttle_activation: a command on the control topic wakes CFB, which wakes the waiting THR
// (the zero-time timer) on the same core, where the NCT streams; from CFB taking the command to
// THR entered (CFB > THR > NCT, as in an nRT node). The commands come from `far_core`.
std::vector<double> Suite::throttle_activations(int nrt_core, int far_core, std::size_t count) {
  const int n = static_cast<int>(count);
  InprocTopic<ControlMsg> control;
  Waker cfb_waker, thr_waker;
  const std::size_t pub = control.add_publisher();
  const std::size_t sub = control.subscribe(cfb_waker);
  std::atomic<bool> done{false}, throttled{false};
  std::atomic<TimeNs> t_taken{0};
  std::vector<double> act;
  act.reserve(static_cast<std::size_t>(n));
  RtThread thr(ThreadSpec{"cal-thr", nrt_core, SchedClass::Fifo, prio::kThr}, [&] {
    while (!done.load(std::memory_order_acquire)) {
      const auto e = thr_waker.epoch();
      if (done.load(std::memory_order_acquire)) break;  // a stop notified before the epoch read
      if (throttled.exchange(false, std::memory_order_acq_rel))
        act.push_back(ns_to_us(now_ns() - t_taken.load(std::memory_order_acquire)));
      else
        thr_waker.wait(e, -1);
    }
  });
  notes_.sched(thr.outcome());
  RtThread cfb(ThreadSpec{"cal-cfb", nrt_core, SchedClass::Fifo, prio::kCfb}, [&] {
    while (!done.load(std::memory_order_acquire)) {
      const auto e = cfb_waker.epoch();
      if (done.load(std::memory_order_acquire)) break;  // a stop notified before the epoch read
      ControlMsg m;
      bool got = false;
      while (control.take(sub, m)) {
        got = true;
        // A command while THR has not entered yet for the previous one: that activation is
        // still running (and will be recorded with its full delay), so this one is not timed.
        if (throttled.load(std::memory_order_acquire)) continue;
        t_taken.store(now_ns(), std::memory_order_release);
        throttled.store(true, std::memory_order_release);
        thr_waker.notify();
      }
      if (!got) cfb_waker.wait(e, -1);
    }
  });
  notes_.sched(cfb.outcome());
  run_on(far_core, prio::kController, "cal-ctl", [&] {
    paced(
        [&](int, TimeNs) {
          ControlMsg m;
          m.command = Command::Thr;
          m.t_cause = now_ns();
          control.publish(pub, m);
        },
        n);
  });
  sleep_until(now_ns() + 10 * kNsPerMs);  // the last activation
  done.store(true, std::memory_order_release);
  cfb_waker.notify();
  thr_waker.notify();
  cfb.join();
  thr.join();
  rethrow_if_failed(cfb);
  rethrow_if_failed(thr);
  return act;
}

// external_read: the controller's core reads the NCT's counters.
std::vector<double> Suite::external_reads(CounterGroup& group, std::size_t group_size,
                                          int far_core) {
  const int n = shape_.cost_samples;
  std::vector<double> reads;
  reads.reserve(static_cast<std::size_t>(n));
  std::array<CounterValue, kMaxGroupEvents> v{};
  run_on(far_core, prio::kController, "cal-ext", [&] {
    paced(
        [&](int, TimeNs) {
          const TimeNs t0 = now_ns();
          group.read(std::span(v.data(), group_size));
          reads.push_back(ns_to_us(now_ns() - t0));
        },
        n);
  });
  return reads;
}

// Middleware / OS costs, each on the hw backend's own pieces, with a bandwidth_read NCT streaming
// on the nRT core (cores[0]) as in a run; the far end (controller) on cores[1].
void Suite::measure_costs() {
  const int nrt_core = cores_[0];
  const int far_core = cores_.size() > 1 ? cores_[1] : cores_[0];
  if (cores_.size() < 2)
    notes_.add(
        "one core only: message_latency, external_read and controller_callback are "
        "measured with both ends on the same core (no controller_callback_local)");
  const int n = shape_.cost_samples;
  auto& costs = m_.costs_us;

  PmcSourceRegistry sources;
  register_builtin(sources);
  // What the hw backend would pick for a scenario of built-in workloads with the default metric
  // (pmc_source auto). reference_mbps: the controller_callback budget below.
  Scenario s;
  s.file = "calibration suite";
  s.regulation.reference_mbps = kReferenceMbps;
  const MetricPlan plan = plan_metric(s, sources);
  notes_.add("pmc source for pmc_callback / external_read: " + plan.source + " (" + plan.why + ")");
  const auto source = sources.find(plan.source)->make();

  auto nct_work = make_kernel(kBwRead, shape_.workload_kb);
  Streamer nct(*nct_work, shape_.workload_kb, nrt_core, prio::kNct, notes_);
  PmcTarget target;
  target.kind = PmcTarget::Kind::Thread;
  target.pid = nct.tid();
  target.work = &nct.counters();
  auto group = source->open(plan.group_events, target);
  const std::unique_ptr<dds::Participant> dds_participant = message_transport();

  message_costs(*group, plan, nrt_core, far_core, dds_participant.get());
  if (!stopping()) {
    step("costs: throttle_activation");
    std::size_t sent = 0;
    costs["throttle_activation"] = cost_rounds(static_cast<std::size_t>(n), [&](std::size_t k) {
      sent += k;
      return throttle_activations(nrt_core, far_core, k);
    });
    if (const std::size_t timed = costs["throttle_activation"].size(); timed < sent)
      notes_.add("throttle_activation: " + std::to_string(sent - timed) + " of " +
                 std::to_string(sent) +
                 " commands came while the previous activation was still running (not timed)");
  }
  if (!stopping()) {
    step("costs: external_read");
    costs["external_read"] = external_reads(*group, plan.group_events.size(), far_core);
  }

  // timer_wakeup: the core time of a thread woken by its own timer on a busy core (the timer
  // interrupt, the switch in and out), on each measured core (VMs' vCPUs differ), pooled.
  if (!stopping()) {
    step("costs: timer_wakeup");
    // Per core: the samples wanted there, taken in rounds.
    const auto on = [&](int core, std::size_t count) {
      std::size_t unmatched = 0;
      const std::vector<double> v =
          cost_rounds(count, [&](std::size_t k) { return timer_wakeups(core, k, unmatched); });
      if (unmatched)
        notes_.add("timer_wakeup on core " + std::to_string(core) + ": " +
                   std::to_string(unmatched) + " of " + std::to_string(v.size() + unmatched) +
                   " wake-ups not seen as a gap of the spinner that began after the timer was "
                   "due (left out)");
      return v;
    };
    const auto un = static_cast<std::size_t>(n);
    std::vector<double> all = on(far_core, far_core == nrt_core ? un : un / 2);
    if (far_core != nrt_core && !stopping()) {
      const std::vector<double> near = on(nrt_core, un - un / 2);
      all.insert(all.end(), near.begin(), near.end());
    }
    costs["timer_wakeup"] = std::move(all);
  }

  // controller_callback: the controller's core time per input woken from another core (a
  // sample published there); controller_callback_local: woken on its own core (a sample from an
  // nRT node beside it, as when it shares the nRT core). See controller_callbacks().
  if (!stopping()) {
    step("costs: controller_callback");
    costs["controller_callback"] = controller_callbacks(plan, nrt_core, far_core);
  }
  if (!stopping() && far_core != nrt_core) {
    step("costs: controller_callback_local");
    costs["controller_callback_local"] = controller_callbacks(plan, nrt_core, nrt_core);
  }

  // preemption: what a wake-up costs a memory stream beyond the gap a spinner sees (above), on
  // the core the controller's costs are measured on. Last: its 100 ms windows of a SCHED_FIFO
  // stream leave the core to the kernel's RT throttling for a while, which the steps above would
  // time.
  if (!stopping()) {
    step("costs: preemption");
    const auto it = costs.find("timer_wakeup");
    std::vector<double> wakeups = it != costs.end() ? it->second : std::vector<double>{};
    if (wakeups.empty()) {
      notes_.add("preemption: not measured (no timer_wakeup sample to take from it)");
    } else {
      std::sort(wakeups.begin(), wakeups.end());
      const std::vector<double> extra = preemptions(far_core, wakeups[wakeups.size() / 2]);
      if (!extra.empty()) costs["preemption"] = extra;
    }
  }
  nct.stop();
}

// `count` paced wake-ups of an empty thread sleeping on its timer (the controller's priority) on
// `core`, where a spinner (an RT job's priority, above the NCT's) sees each as a gap in its own
// progress: the timer interrupt, the switch in, the switch out. What every timer-driven callback
// (a PMC sample, the controller's reads and period boundaries) costs its core before its own work.
std::vector<double> Suite::timer_wakeups(int core, std::size_t count, std::size_t& unmatched) {
  GapSpinner spinner("cal-tspin", core, count * 8, notes_);
  std::vector<TimeNs> due, woke;
  due.reserve(count);
  woke.reserve(count);
  RtThread sleeper(ThreadSpec{"cal-timer", core, SchedClass::Fifo, prio::kController}, [&] {
    paced(
        [&](int, TimeNs at) {
          woke.push_back(now_ns());
          due.push_back(at);
        },
        static_cast<int>(count));
  });
  notes_.sched(sleeper.outcome());
  sleeper.join();
  spinner.stop();
  rethrow_if_failed(sleeper);
  std::size_t missed = 0;
  std::vector<double> out = gaps_at(spinner.gaps(), due, woke, kWakeLeadNs, missed);
  unmatched += missed;
  return out;
}

// Rounds of `round(k)` (k: the samples still wanted; it returns those it could time) until `n`
// are timed or kCostRounds rounds have run. A wake-up that the kernel's RT throttling or the host
// held back is not timed (its gap began before its cause; a command met the previous activation
// still running), and such holds come in bursts: in 1 of 200 runs of the tiny suite on the Intel
// Xeon VM of 2026-12-06, one round timed 5 of its 20 throttle activations.
std::vector<double> Suite::cost_rounds(
    std::size_t n, const std::function<std::vector<double>(std::size_t)>& round) {
  std::vector<double> out;
  for (int r = 0; r < kCostRounds && out.size() < n && !stopping(); ++r) {
    const std::vector<double> more = round(n - out.size());
    out.insert(out.end(), more.begin(), more.end());
  }
  return out;
}

// Pairs of timed windows of bandwidth_read over the in-L3 working set on `core` (the RT job's
// priority), one alone and one beside an empty thread woken by its timer every cost_spacing_us on
// the same core (the controller's priority), in alternating order so that drift hits both alike.
// Per pair: the stream's lost time per wake-up, window x (1 - alone / beside) / wake-ups, less
// `wakeup_us` (what a spinner loses to the same wake-up: timer_wakeup's median). What is left is
// what the stream loses on top: its prefetches and lines in flight start again after each
// preemption. On the development VM (2026-12-06, Intel Xeon) 20-25 us with 0, 25 or 60 us of work
// in the woken thread: a cost per preemption, not a share of the preempting thread's time.
std::vector<double> Suite::preemptions(int core, double wakeup_us) {
  const double kb = shape_.in_l3_kb > 0 ? shape_.in_l3_kb : shape_.workload_kb;
  std::unique_ptr<BuiltinWorkload> work;  // built on `core`: its pages local to it
  RtThread builder(ThreadSpec{"cal-mkp", core, SchedClass::Other, prio::kNct},
                   [&] { work = make_kernel(kBwRead, kb); });
  builder.join();
  notes_.sched(builder.outcome());
  rethrow_if_failed(builder);
  std::vector<double> out;
  int dropped = 0;
  const int pairs = preemption_pairs(shape_);
  const double share = std::min(0.5, wakeup_us / shape_.cost_spacing_us);  // the wake-ups' time
  for (int i = 0; i < pairs && !stopping(); ++i) {
    std::optional<StreamWindow> alone, beside;
    if (i % 2 == 0) {
      alone = stream_window(*work, kb, core, false, 0.0);
      beside = stream_window(*work, kb, core, true, share);
    } else {
      beside = stream_window(*work, kb, core, true, share);
      alone = stream_window(*work, kb, core, false, 0.0);
    }
    // A pause after each pair: back to back, the SCHED_FIFO stream would meet the kernel's RT
    // throttling (sched_rt_runtime_us: 95 % of each second), which took the core from a quarter
    // of the pairs on the development VM.
    sleep_until(now_ns() + static_cast<TimeNs>(preemption_window_ms(shape_) * 0.6e6));
    if (!alone || !beside || beside->wakeups <= 0) {
      ++dropped;
      continue;
    }
    const double lost_us =
        preemption_window_ms(shape_) * 1e3 * (1.0 - alone->ns_per_line / beside->ns_per_line);
    out.push_back(lost_us / beside->wakeups - wakeup_us);
  }
  if (dropped)
    notes_.add("preemption on core " + std::to_string(core) + ": " + std::to_string(dropped) +
               " of " + std::to_string(pairs) +
               " pairs left out (the stream made no progress or was off its core)");
  return out;
}

// One timed window of `w` streaming on `core`, beside an empty timer-woken thread there when
// `waker`: ns per line and the wake-ups within the window. Empty when the stream made no
// progress or was off its core for more than the suite allows (kMinOnCore) beyond
// `waker_share`, the share of the window the wake-ups themselves take.
std::optional<Suite::StreamWindow> Suite::stream_window(BuiltinWorkload& w, double kb, int core,
                                                        bool waker, double waker_share) {
  Streamer s(w, kb, core, prio::kRt, notes_);
  const TimeNs warm_by = now_ns() + static_cast<TimeNs>(shape_.warmup_ms * 1e6);
  while (!s.warm() && now_ns() < warm_by)
    sleep_until(now_ns() + 200 * kNsPerUs);
  std::atomic<bool> stop{false};
  std::atomic<int> woke{0};
  std::optional<RtThread> sleeper;
  if (waker) {
    const auto spacing = static_cast<TimeNs>(shape_.cost_spacing_us * 1e3);
    sleeper.emplace(ThreadSpec{"cal-pwake", core, SchedClass::Fifo, prio::kController}, [&] {
      for (TimeNs next = now_ns() + spacing; !stop.load(std::memory_order_relaxed);
           next += spacing) {
        sleep_until(next);
        woke.fetch_add(1, std::memory_order_relaxed);
      }
    });
    notes_.sched(sleeper->outcome());
  }
  const TimeNs cpu0 = s.cpu_ns();
  const int w0 = woke.load(std::memory_order_relaxed);
  const TimeNs t0 = now_ns();
  const std::uint64_t u0 = s.units();
  sleep_until(t0 + static_cast<TimeNs>(preemption_window_ms(shape_) * 1e6));
  const std::uint64_t u1 = s.units();
  const TimeNs t1 = now_ns();
  const int w1 = woke.load(std::memory_order_relaxed);
  const TimeNs cpu1 = s.cpu_ns();
  stop.store(true, std::memory_order_relaxed);
  if (sleeper) {
    sleeper->join();
    rethrow_if_failed(*sleeper);
  }
  s.stop();
  const double ran = cpu0 >= 0 && cpu1 >= 0
                         ? static_cast<double>(cpu1 - cpu0) / static_cast<double>(t1 - t0)
                         : 1.0;
  if (u1 <= u0 || ran < kMinOnCore - waker_share) return std::nullopt;
  return StreamWindow{static_cast<double>(t1 - t0) / static_cast<double>(u1 - u0), w1 - w0};
}

// One controller callback per paced sample from `feed_core`, on `ctl_core`: woken by the sample,
// one input to the controller engine (a sample, a due wake-up, an RT signal), publishing the
// commands it produces, back to sleep. Synthetic counters, 1 ms apart in engine time, that use
// the budget of a 5 ms interval window in about 2.5 samples, so THR / REPLENISH commands flow.
//
// The controller engine as controller_callbacks() drives it: the interval policy regulating one RT
// job's account over the planned metric, fed self-sampled counters that cross its budget in a few
// samples; its commands are published on an in-process control topic and drained at once (nobody
// sleeps on them). Its time is synthetic, so the regulation logic is the same on every host.
class CallbackController {
 public:
  explicit CallbackController(const MetricPlan& plan)
      : rc_(regulator_config(plan)),
        per_sample_(lines_per_sample(rc_)),
        driver_(driver_config(), std::make_unique<Regulator>(rc_, interval_policy()), &meter_),
        pub_(control_.add_publisher()),
        sub_(control_.subscribe(nrt_waker_)),
        counters_(rc_.metric.events.size()) {}

  // The RT job active: regulation on.
  void start() {
    driver_.rt_signal(t_, 0, true, out_);
    drain();
  }

  // One sample 1 ms after the last: the engine's step (the sample, a wake-up due, or now and then
  // an activation edge), its commands published and drained.
  void on_sample() {
    t_ += kNsPerMs;
    for (auto& c : counters_) {
      c.value += per_sample_;
      c.time_enabled_ns += kNsPerMs;
      c.time_running_ns += kNsPerMs;
    }
    meter_.bytes += static_cast<double>(per_sample_) * kLineBytes;
    if (i_++ % 200 == 199) {  // an activation edge now and then
      driver_.rt_signal(t_, 0, false, out_);
      driver_.rt_signal(t_, 0, true, out_);
    } else if (auto due = driver_.next_wakeup(); due && *due <= t_) {
      driver_.wake(t_, out_);
    } else {
      driver_.sample(t_, 0, counters_, t_, out_);
    }
    for (const auto& c : out_.commands) {
      ControlMsg m;
      m.command = c.command;
      m.t_cause = c.cause;
      control_.publish(pub_, m);
    }
    drain();
  }

 private:
  struct Meter : EntityMeter {
    double bytes = 0.0;
    EntityReading read(std::size_t, TimeNs) override { return {bytes, 0.0, 0.0}; }
  };

  static PolicyParams policy_params() {
    PolicyParams params;
    params.threshold_pct = 20.0;
    params.reference_mbps = kReferenceMbps;
    params.regulation_period_ns = 5 * kNsPerMs;
    return params;
  }
  static RegulatorConfig regulator_config(const MetricPlan& plan) {
    RegulatorConfig rc;
    rc.rt_count = 1;
    rc.account_of_entity = {0};
    rc.metric = plan.spec;
    return rc;
  }
  // Lines per sample: the budget of a regulation period crossed in 2.5 samples.
  static std::uint64_t lines_per_sample(const RegulatorConfig& rc) {
    const PolicyParams params = policy_params();
    const double budget =
        budget_bytes(100.0, account_rate_mbps(params, 0), params.regulation_period_ns);
    double weights = 0.0;
    for (const auto& e : rc.metric.events)
      weights += e.weight;
    return static_cast<std::uint64_t>(budget / 2.5 /
                                      (weights * static_cast<double>(rc.metric.line_bytes)));
  }
  static ControllerDriverConfig driver_config() {
    ControllerDriverConfig dc;
    dc.sampling = Sampling::Self;
    dc.sampling_period_ns = kNsPerMs;
    return dc;
  }
  std::unique_ptr<Policy> interval_policy() {
    register_builtin(policies_);
    return policies_.make("interval", policy_params());
  }
  void drain() {
    ControlMsg m;
    while (control_.take(sub_, m)) {
    }
    out_.clear();
  }

  PolicyRegistry policies_;
  RegulatorConfig rc_;
  std::uint64_t per_sample_;
  Meter meter_;
  ControllerDriver driver_;
  InprocTopic<ControlMsg> control_;
  Waker nrt_waker_;  // nobody sleeps on it: the controller drains the ring itself
  std::size_t pub_, sub_;
  std::vector<CounterValue> counters_;
  DriverOutput out_;
  TimeNs t_ = kNsPerS;
  int i_ = 0;
};

// Each wake-up's cost when the controller shares the feed's core: to the first publish return
// after it (the publish it preempted), if within 1 ms; `unmatched` counts the others.
std::vector<double> until_returned(const std::vector<TimeNs>& woke,
                                   const std::vector<TimeNs>& returned, std::size_t& unmatched) {
  std::vector<double> cb;
  cb.reserve(woke.size());
  std::size_t r = 0;
  for (const TimeNs w : woke) {
    while (r < returned.size() && returned[r] < w)
      ++r;
    if (r < returned.size() && returned[r] - w <= kNsPerMs)
      cb.push_back(ns_to_us(returned[r] - w));
    else
      ++unmatched;
  }
  return cb;
}

// From another core (controller_callback): a spinner on the controller's core (an RT job's
// priority, below the controller's) sees the whole cost as a gap in its own progress: switch in,
// the engine step, publishing the commands, switch out. That gap is what the sim charges per
// callback on the controller's core (it preempts whatever runs there).
// On its own core (controller_callback_local): the feed (the PMC thread's priority) is preempted
// inside its publish, as an nRT node's PMC callback is by a controller beside it; the cost is
// from the controller awake (the switch in is local_message_latency's) to the feed running again:
// the engine step, publishing the commands, switch out. The NCT streams on the nRT core meanwhile.
std::vector<double> Suite::controller_callbacks(const MetricPlan& plan, int feed_core,
                                                int ctl_core) {
  const bool local = feed_core == ctl_core;
  const auto n = static_cast<std::size_t>(shape_.cost_samples);
  // Wake-ups that could not be timed (the spinner descheduled by the host around them, two
  // samples taken in one wake-up) are left out; further rounds take the shortfall, up to
  // kCostRounds in all (on the Xeon VM of 2026-11-28, 8 to 20 of 20 in one round).
  std::size_t unmatched = 0, woken = 0;
  std::vector<double> cb = cost_rounds(n, [&](std::size_t k) {
    return controller_callback_round(plan, feed_core, ctl_core, k, unmatched, woken);
  });
  if (unmatched)
    notes_.add(std::string(local ? "controller_callback_local: " : "controller_callback: ") +
               std::to_string(unmatched) + " of " + std::to_string(woken) +
               (local ? " wake-ups not followed by the feed's publish returning (left out)"
                      : " wake-ups not seen as a gap of the spinner on the controller's core "
                        "(left out)"));
  return cb;
}

// One round of controller_callbacks(): `count` samples fed, the costs of the wake-ups it could
// time; adds the wake-ups to `woken` and those it could not time to `unmatched`.
std::vector<double> Suite::controller_callback_round(const MetricPlan& plan, int feed_core,
                                                     int ctl_core, std::size_t count,
                                                     std::size_t& unmatched, std::size_t& woken) {
  const bool local = feed_core == ctl_core;
  const int n = static_cast<int>(count);
  CallbackController engine(plan);

  InprocTopic<SampleMsg> samples;
  Waker ctl_waker;
  const std::size_t sample_pub = samples.add_publisher();
  const std::size_t sample_sub = samples.subscribe(ctl_waker);
  std::vector<TimeNs> woke;       // the controller's wake-ups (monotonic ns)
  std::vector<TimeNs> published;  // the first sample each wake-up took: when it was published
  std::vector<TimeNs> returned;   // local: the feed's publish returned (monotonic ns)
  woke.reserve(static_cast<std::size_t>(n));
  published.reserve(static_cast<std::size_t>(n));
  returned.reserve(static_cast<std::size_t>(n));
  std::atomic<bool> done{false};
  std::optional<GapSpinner> spinner;
  if (!local) spinner.emplace("cal-spin", ctl_core, static_cast<std::size_t>(n) * 8, notes_);
  RtThread controller(ThreadSpec{"cal-ctl", ctl_core, SchedClass::Fifo, prio::kController}, [&] {
    engine.start();
    while (!done.load(std::memory_order_acquire)) {
      const auto e = ctl_waker.epoch();
      if (done.load(std::memory_order_acquire)) break;  // a stop notified before the epoch read
      SampleMsg msg;
      bool got = false;
      while (samples.take(sample_sub, msg)) {
        if (!got) {
          woke.push_back(now_ns());
          published.push_back(msg.t_published);
        }
        got = true;
        engine.on_sample();
      }
      if (!got) ctl_waker.wait(e, -1);
    }
  });
  notes_.sched(controller.outcome());
  RtThread feed(ThreadSpec{"cal-feed", feed_core, SchedClass::Fifo, prio::kPmc}, [&] {
    paced(
        [&](int, TimeNs) {
          SampleMsg m;
          m.t_published = now_ns();
          samples.publish(sample_pub, m);
          if (local) returned.push_back(now_ns());
        },
        n);
  });
  notes_.sched(feed.outcome());
  feed.join();
  rethrow_if_failed(feed);
  // Let the last callback finish before stopping the threads.
  sleep_until(now_ns() + static_cast<TimeNs>(shape_.cost_spacing_us * 1e3));
  done.store(true, std::memory_order_release);
  ctl_waker.notify();
  controller.join();
  if (spinner) spinner->stop();
  rethrow_if_failed(controller);

  // Each wake-up's cost: local, to the feed's publish return after it; else the spinner's gap
  // around it that began after the sample was published.
  std::size_t missed = 0;
  std::vector<double> cb = local ? until_returned(woke, returned, missed)
                                 : gaps_at(spinner->gaps(), published, woke, 0, missed);
  unmatched += missed;
  woken += woke.size();
  return cb;
}

SuiteResult Suite::run() {
  const auto t_start = std::chrono::steady_clock::now();
  m_.host = opt_.host;
  if (m_.host.date.empty()) m_.host.date = iso_now();
  // The engine thread sleeps while kernels stream; above them, so it ends each window on time.
  ScopedSched engine(ThreadSpec{"", -1, SchedClass::Fifo, prio::kEngine});
  notes_.sched(engine.outcome());

  const auto blocks = blocks_for(shape_, static_cast<int>(cores_.size()));
  if (cores_.size() < 2)
    notes_.add("one core only: no co-run measurements (bandwidth-latency, matrix)");
  // Every configuration to its cap, and the cost blocks; lowered as configurations finish early.
  steps_ = kCostSteps - (cores_.size() < 2 ? 1 : 0);  // no local callback block on one core
  for (const auto& b : blocks)
    steps_ += static_cast<int>(b.configs.size()) * shape_.repetitions.max_windows +
              (b.co ? 1 : 0);       // a co-run block's contention probe after it
  if (blocks.size() > 1) ++steps_;  // the probe before the first

  const auto keep = corun_measured(blocks);
  for (const auto& b : blocks) {
    if (stopping()) break;
    if (b.configs.empty()) continue;
    if (b.co) {
      measure_corun_block(b);
      continue;
    }
    measure_block(b, "isolation");
    // the isolation-only buffers, before the co-runners' own
    std::erase_if(measured_, [&](const auto& kv) { return !keep.count(kv.first); });
  }
  if (!m_.contention.empty()) {
    std::string text = "DRAM-interference probes (bandwidth_read " + kb_text(shape_.dram_kb) +
                       " on CPU " + std::to_string(cores_[0]) + ", alone and beside one on CPU " +
                       std::to_string(cores_[1]) + "), around the co-run blocks:";
    for (const auto& p : m_.contention) {
      char buf[32];
      std::snprintf(buf, sizeof buf, " %.2fx", p.ratio);
      text += buf;
    }
    if (blocks_retaken_ > 0) {
      text += "; " + std::to_string(blocks_retaken_) +
              " co-run block(s) taken again: a probe around them was in another state than most "
              "(the host moved the vCPUs?)";
      char buf[160];
      std::snprintf(buf, sizeof buf,
                    "; waited %.1f s for that state before the retakes (at most %.0f s in all), "
                    "%d probe(s) in another state not recorded",
                    state_waited_s_, shape_.state_wait_s, state_wait_probes_);
      text += buf;
    }
    notes_.add(text);
  }
  if (!unsettled_.empty()) {
    std::string text =
        "co-run blocks kept in another DRAM-interference state than most of the suite's "
        "probes after " +
        std::to_string(kStateAttempts) + " attempts (the fit leaves their runs out):";
    for (const auto& u : unsettled_)
      text += (u == unsettled_.front() ? " " : "; ") + u;
    notes_.add(text);
  }
  measured_.clear();  // the buffers, before the costs' own
  if (!stopping()) measure_costs();
  if (!windows_.empty()) {
    std::vector<double> w(windows_.begin(), windows_.end());
    std::string text = std::to_string(precise_) + " of " + std::to_string(windows_.size()) +
                       " measurements reached +-" + pct_text(shape_.repetitions.precision_pct) +
                       " (95 % confidence interval of the median window)";
    if (capped_ > 0)
      text += "; " + std::to_string(capped_) + " stopped at the cap of " +
              std::to_string(shape_.repetitions.max_windows) + " windows (widest +-" +
              (std::isfinite(widest_) ? pct_text(widest_) : std::string("unknown")) + ")";
    text += "; windows per measurement: median " +
            std::to_string(static_cast<int>(std::lround(median(w)))) + ", at most " +
            std::to_string(*std::max_element(windows_.begin(), windows_.end()));
    notes_.add(text);
  }
  if (retaken_ + dropped_ > 0)
    notes_.add(std::to_string(retaken_ + dropped_) +
               " timed windows had a kernel off its core for more than " +
               std::to_string(static_cast<int>(std::lround((1.0 - kMinOnCore) * 100))) +
               " % of the window (RT throttling, other tasks): " + std::to_string(retaken_) +
               " taken again, " + std::to_string(dropped_) + " dropped after " +
               std::to_string(kOnCoreAttempts) + " attempts");

  SuiteResult r;
  r.stopped = stopping();
  m_.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  r.measurements = std::move(m_);
  r.notes = notes_.take();
  return r;
}

}  // namespace

std::vector<double> gaps_at(std::span<const SpinGap> gaps, const std::vector<TimeNs>& caused,
                            const std::vector<TimeNs>& woke, TimeNs lead, std::size_t& unmatched) {
  if (caused.size() != woke.size()) throw std::invalid_argument("gaps_at: one cause per wake-up");
  std::vector<double> out;
  out.reserve(woke.size());
  unmatched = 0;
  std::size_t g = 0;
  for (std::size_t i = 0; i < woke.size(); ++i) {
    while (g < gaps.size() && gaps[g].end < woke[i])
      ++g;
    if (g < gaps.size() && gaps[g].start <= woke[i] && gaps[g].start >= caused[i] - lead)
      out.push_back(ns_to_us(gaps[g].end - gaps[g].start));
    else
      ++unmatched;
  }
  return out;
}

double median_ci95_pct(std::vector<double> values) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const std::size_t n = values.size();
  if (n < 6) return kInf;
  std::sort(values.begin(), values.end());
  const double med = n % 2 ? values[n / 2] : (values[n / 2 - 1] + values[n / 2]) / 2.0;
  if (!(med > 0.0)) return kInf;
  // k: the largest with P(B <= k - 1) <= 2.5 %, B ~ Binomial(n, 1/2) (log-space: 0.5^n underflows).
  const double nd = static_cast<double>(n);
  double below = 0.0;  // P(B <= j)
  std::size_t k = 0;
  for (std::size_t j = 0; j < n / 2; ++j) {
    const double jd = static_cast<double>(j);
    below += std::exp(std::lgamma(nd + 1.0) - std::lgamma(jd + 1.0) - std::lgamma(nd - jd + 1.0) -
                      nd * std::log(2.0));
    if (below > 0.025) break;
    k = j + 1;
  }
  if (k == 0) return kInf;
  return (values[n - k] - values[k - 1]) / 2.0 / med * 100.0;
}

bool repetitions_done(const std::vector<double>& windows, int rounds, const RepetitionRule& rule) {
  if (rounds >= rule.max_windows) return true;
  return static_cast<int>(windows.size()) >= std::max(1, rule.min_windows) &&
         median_ci95_pct(windows) <= rule.precision_pct;
}

SuitePlan plan_suite(const SuiteShape& shape, int cores) {
  SuitePlan p;
  const auto blocks = blocks_for(shape, std::max(1, cores));
  // Every measured kernel is built once (the isolation block builds them all); the co-run blocks
  // keep those they use, and build one co-runner per co-runner core for their block.
  std::set<std::pair<std::string, double>> measured;
  double iso_kb = 0.0;
  for (const auto& b : blocks) {
    p.configurations += static_cast<int>(b.configs.size());
    for (const auto& c : b.configs)
      if (measured.insert({c.kernel, c.kb}).second && !b.co) iso_kb += c.kb;
  }
  double touched_kb = 0.0, chase_lines = 0.0, kept_kb = 0.0;
  for (const auto& [kernel, kb] : measured) {
    touched_kb += kb;
    if (kernel == kLatency) chase_lines += static_cast<double>(lines_of(kb));
  }
  for (const auto& [kernel, kb] : corun_measured(blocks))
    kept_kb += kb;
  double peak_kb = iso_kb;
  int probes = 0;
  for (const auto& b : blocks)
    if (b.co) {
      const double co_kb = max_corunners(b) * b.co->kb;
      touched_kb += co_kb;
      peak_kb = std::max(peak_kb, kept_kb + co_kb);
      probes += probes == 0 ? 2 : 1;  // before the first block, and after each
    }
  // Each contention probe builds one co-runner DRAM set (the measured one is kept); between
  // blocks, so within the peak of a block of DRAM co-runners.
  touched_kb += probes * shape.dram_kb;
  p.max_windows = p.configurations * std::max(0, shape.repetitions.max_windows) +
                  probes * 2 * kContentionRounds;
  p.touched_mb = touched_kb / 1024.0;
  p.peak_mb = peak_kb / 1024.0;
  p.seconds =
      p.max_windows * (shape.window_ms + shape.warmup_ms + kWindowOverheadMs) / 1e3 +
      p.touched_mb / kFirstTouchMBps + chase_lines * kChaseNsPerLine * 1e-9 +
      kCostSteps * shape.cost_samples * shape.cost_spacing_us * 1e-6 +
      preemption_pairs(shape) * (2.6 * preemption_window_ms(shape) + 2 * shape.warmup_ms) / 1e3;
  return p;
}

double read_mem_available_kb() {
  std::ifstream f("/proc/meminfo");
  for (std::string line; std::getline(f, line);)
    if (line.rfind("MemAvailable:", 0) == 0) {
      try {
        return std::stod(line.substr(13));  // "MemAvailable:   22524000 kB"
      } catch (const std::exception&) {
        return 0.0;
      }
    }
  return 0.0;
}

SuiteShape shape_for(const calibration::HostFacts& host, bool quick, int cores,
                     double mem_available_kb) {
  cores = std::max(1, cores);
  SuiteShape s;
  const double l2 = host.l2_kb > 0.0 ? host.l2_kb : 256.0;
  const double l3 = host.l3_kb_per_cluster > 0.0 ? host.l3_kb_per_cluster : 8192.0;
  s.in_l3_kb = std::clamp(std::max(4.0 * l2, 2048.0), 16.0, std::max(16.0, l3 / 2.0));
  s.workload_kb = 2048.0;
  for (int n = 1; n < cores - 1; n *= 2)
    s.corunner_counts.push_back(n);
  if (cores > 1) s.corunner_counts.push_back(cores - 1);
  int ceiling = 0;
  double budget_s = 0.0;
  if (quick) {
    s.repetitions = {6, 0, 4.0};
    ceiling = 30;
    budget_s = kQuickBudgetS;
    s.window_ms = 20.0;
    s.warmup_ms = 20.0;
    s.cost_samples = 1000;
  } else {
    s.repetitions = {9, 0, 2.0};
    ceiling = 100;
    budget_s = kFullBudgetS;
    s.window_ms = 30.0;
    s.warmup_ms = 30.0;
    s.cost_samples = 3000;
  }
  s.repetitions.max_windows = s.repetitions.min_windows;  // the plan's memory does not depend on it

  // The DRAM set: 4x the LLC, else 3x or 2x where the buffers would not fit in memory.
  const auto set_dram = [&](double dram) {
    s.dram_kb = std::round(std::max(dram, 16384.0));
    s.isolation_kb.clear();
    if (quick)
      s.isolation_kb = {std::max(16.0, l2 / 2.0)};
    else
      for (double kb = 16.0; kb < s.dram_kb; kb *= 2.0)
        s.isolation_kb.push_back(kb);
  };
  const double budget_kb = kMemFraction * mem_available_kb;
  const std::string fraction = std::to_string(static_cast<int>(std::lround(kMemFraction * 100))) +
                               " % of MemAvailable (" + mb_text(mem_available_kb) + ")";
  double first_peak_kb = 0.0;
  for (const double factor : {4.0, 3.0, 2.0}) {
    set_dram(factor * l3);
    const double peak_kb = plan_suite(s, cores).peak_mb * 1024.0;
    if (mem_available_kb <= 0.0 || peak_kb <= budget_kb) {
      if (factor < 4.0)
        s.notes.push_back("DRAM working set " + kb_text(s.dram_kb) + ", " +
                          std::to_string(static_cast<int>(factor)) +
                          "x the LLC, not 4x: 4x would hold " + mb_text(first_peak_kb) +
                          " of buffers at once, over " + fraction);
      break;
    }
    if (factor == 4.0) first_peak_kb = peak_kb;
    if (factor == 2.0)
      throw RunError(
          "calibration suite: not enough memory for a working set beyond the last-level cache: "
          "a DRAM set of " +
          mb_text(s.dram_kb) + " (2x the " + mb_text(l3) +
          " LLC, the least that measures DRAM) on the measuring core and on each of its " +
          std::to_string(cores - 1) + " co-runner cores needs " + mb_text(peak_kb) +
          " of buffers at once; " + mb_text(budget_kb) + " are available to it (" + fraction + ")");
  }

  // The cap on rounds: the worst case (every configuration to its cap) within the time budget.
  const SuitePlan one = [&] {
    SuiteShape t = s;
    t.repetitions.max_windows = 1;
    return plan_suite(t, cores);
  }();
  const double per_round_s =
      one.configurations * (s.window_ms + s.warmup_ms + kWindowOverheadMs) / 1e3;
  const double fixed_s = one.seconds - per_round_s;
  const int fits = per_round_s > 0.0
                       ? static_cast<int>(std::floor((budget_s - fixed_s) / per_round_s))
                       : ceiling;
  s.repetitions.max_windows = std::clamp(fits, s.repetitions.min_windows, ceiling);
  if (fits < s.repetitions.min_windows)
    s.notes.push_back("even " + std::to_string(s.repetitions.min_windows) +
                      " windows per measurement exceed the suite's time budget of " +
                      std::to_string(static_cast<int>(budget_s)) + " s on " +
                      std::to_string(cores) + " cores");
  return s;
}

ContentionResult measure_contention(const ContentionOptions& options) {
  std::vector<int> cores = options.cores;
  if (cores.empty()) {
    const auto usable = usable_cpus();
    cores.assign(usable.begin(),
                 usable.begin() + static_cast<long>(std::min<std::size_t>(2, usable.size())));
  }
  if (cores.size() != 2)
    throw RunError("contention probe: needs two CPUs (one measured, one co-runner); " +
                   std::to_string(cores.size()) + " given or usable");
  SuiteOptions suite_options;
  suite_options.host = options.host;
  suite_options.stop = options.stop;
  const double avail_kb =
      options.mem_available_kb > 0.0 ? options.mem_available_kb : read_mem_available_kb();
  SuiteShape shape = shape_for(options.host, true, 2, avail_kb);
  if (options.working_set_kb > 0.0) shape.dram_kb = options.working_set_kb;
  Suite suite(suite_options, shape, cores);
  auto probe = suite.contention_only();
  if (!probe) throw RunError("contention probe: stopped before a round completed");
  return {*probe, suite.take_notes()};
}

SuiteResult run_suite(const SuiteOptions& options) {
  std::vector<int> cores = options.cores;
  if (cores.empty()) {
    const auto usable = usable_cpus();
    const auto n = static_cast<std::size_t>(std::max(1, options.host.cores_per_cluster));
    cores.assign(usable.begin(), usable.begin() + static_cast<long>(std::min(n, usable.size())));
  }
  if (cores.empty()) throw RunError("calibration suite: no usable CPU");
  const int ncores = static_cast<int>(cores.size());
  const double avail_kb =
      options.mem_available_kb > 0.0 ? options.mem_available_kb : read_mem_available_kb();
  const SuiteShape shape =
      options.shape ? *options.shape : shape_for(options.host, options.quick, ncores, avail_kb);
  const SuitePlan plan = plan_suite(shape, ncores);
  if (options.planned) options.planned(plan);
  Suite suite(options, shape, cores);
  SuiteResult r = suite.run();
  std::string used = "cores: measured on CPU " + std::to_string(cores[0]);
  if (cores.size() > 1) {
    used += ", co-runners and far ends on CPU";
    for (std::size_t i = 1; i < cores.size(); ++i)
      used += (i > 1 ? "," : " ") + std::to_string(cores[i]);
  }
  std::string sets = "working sets: DRAM " + kb_text(shape.dram_kb);
  if (options.host.l3_kb_per_cluster > 0.0) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", shape.dram_kb / options.host.l3_kb_per_cluster);
    sets += std::string(" (") + buf + "x the LLC, " + kb_text(options.host.l3_kb_per_cluster) + ")";
  }
  sets += ", in-L3 " + kb_text(shape.in_l3_kb) + ", workloads " + kb_text(shape.workload_kb);
  if (!shape.isolation_kb.empty())
    sets += ", isolation also at " + kb_text(shape.isolation_kb.front()) +
            (shape.isolation_kb.size() > 1 ? " to " + kb_text(shape.isolation_kb.back()) : "");
  std::string counts = "co-runner counts";
  const auto blocks = blocks_for(shape, ncores);
  std::set<int> ns;
  for (const auto& b : blocks)
    for (const auto& c : b.configs)
      if (c.n > 0) ns.insert(c.n);
  for (int n : ns)
    counts += (n == *ns.begin() ? " " : ", ") + std::to_string(n);
  if (ns.empty()) counts += " none";
  sets += "; " + counts + " (each co-runner streams its own set)";
  const auto& rule = shape.repetitions;
  std::string windows = "windows of " + std::to_string(static_cast<int>(shape.window_ms)) +
                        " ms (after up to " + std::to_string(static_cast<int>(shape.warmup_ms)) +
                        " ms of warm-up) until the 95 % confidence interval of their median is "
                        "within +-" +
                        pct_text(rule.precision_pct) + ", at least " +
                        std::to_string(rule.min_windows) + ", at most " +
                        std::to_string(rule.max_windows) + " per measurement";
  char est[64];
  std::snprintf(est, sizeof est, "%.0f s", plan.seconds);
  std::string planned = "plan: " + std::to_string(plan.configurations) + " measurements, at most " +
                        std::to_string(plan.max_windows) + " windows; buffers " +
                        mb_text(plan.peak_mb * 1024.0) + " at the peak";
  if (avail_kb > 0.0) planned += " (MemAvailable " + mb_text(avail_kb) + ")";
  planned +=
      ", " + mb_text(plan.touched_mb * 1024.0) + " first-touched in all; worst case about " + est;
  std::vector<std::string> head = {used, sets, windows, planned};
  if (avail_kb <= 0.0 && !options.shape)
    head.push_back("MemAvailable unknown (/proc/meminfo): working sets not checked against memory");
  head.insert(head.end(), shape.notes.begin(), shape.notes.end());
  r.notes.insert(r.notes.begin(), head.begin(), head.end());
  return r;
}

}  // namespace rosguard::hw

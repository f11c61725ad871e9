// Built-in kernels: bandwidth_read / bandwidth_write (IsolBench-like: sequential, one access per
// 64-byte line over the working set), latency (a pointer chase: one dependent load per line, in
// the order of a random cyclic permutation, so neither the prefetcher nor memory-level
// parallelism hides the load-to-use latency) and proxies for the SD-VBS names (a line touch plus a
// calibrated amount of dependent ALU work per line, to reach a target bandwidth on this host).
#include <sys/mman.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <random>

#include "core/error.h"
#include "hw/common/clock.h"
#include "hw/workload/workload.h"
#include "results/results.h"

namespace rosguard::hw {
namespace {

constexpr std::size_t kLine = 64;
constexpr std::size_t kWordsPerLine = kLine / sizeof(std::uint64_t);
constexpr std::uint64_t kChunkLines = WorkCounters::kChunkLines;

class Buffer {
 public:
  explicit Buffer(std::size_t bytes) : bytes_(bytes) {
    void* p = ::mmap(nullptr, bytes_, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (p == MAP_FAILED) throw RunError("cannot map a " + std::to_string(bytes_) + "-byte buffer");
    data_ = static_cast<std::uint64_t*>(p);
    // Not in forked children (the supervisor of an external command is a fork of rosguard):
    // shared with a child, every page would be copied on the kernel's next write to it.
    ::madvise(data_, bytes_, MADV_DONTFORK);
    std::memset(data_, 1, bytes_);  // pre-fault: no page fault during a run
  }
  ~Buffer() { ::munmap(data_, bytes_); }
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;
  std::uint64_t* data() const { return data_; }
  std::size_t lines() const { return bytes_ / kLine; }

 private:
  std::size_t bytes_;
  std::uint64_t* data_;
};

class BandwidthKernel : public BuiltinWorkload {
 public:
  BandwidthKernel(bool write, std::size_t working_set_kb, std::uint64_t passes)
      : write_(write), buf_(working_set_kb * 1024), passes_(passes) {}

  std::string_view kernel() const override { return write_ ? "bandwidth_write" : "bandwidth_read"; }
  std::uint64_t units_per_run() const override { return buf_.lines() * passes_; }

  double run(const std::atomic<bool>& stop, WorkCounters& c) override {
    volatile std::uint64_t* p = buf_.data();
    const std::uint64_t lines = buf_.lines();
    std::uint64_t done = 0, sum = 0;
    CountWriter count(c, write_ ? c.lines_written : c.lines_read);
    for (std::uint64_t pass = 0; pass < passes_; ++pass) {
      for (std::uint64_t base = 0; base < lines; base += kChunkLines) {
        const std::uint64_t end = std::min(lines, base + kChunkLines);
        if (write_)
          for (std::uint64_t i = base; i < end; ++i)
            p[i * kWordsPerLine] = i + pass;
        else
          for (std::uint64_t i = base; i < end; ++i)
            sum += p[i * kWordsPerLine];
        count.retire(end - base);
        done += end - base;
        if (stop.load(std::memory_order_relaxed)) return finish(done, sum);
      }
    }
    return finish(done, sum);
  }

 private:
  double finish(std::uint64_t done, std::uint64_t sum) {
    sink_ = sum;
    return static_cast<double>(done) / static_cast<double>(units_per_run());
  }

  bool write_;
  Buffer buf_;
  std::uint64_t passes_;
  volatile std::uint64_t sink_ = 0;
};

// Pointer chase: word 0 of each line holds the index of the next line (chase_cycle), so each load
// depends on the previous one. One unit = one hop = one line loaded.
class LatencyKernel : public BuiltinWorkload {
 public:
  LatencyKernel(std::size_t working_set_kb, std::uint64_t passes)
      : buf_(working_set_kb * 1024), passes_(passes) {
    const auto next = chase_cycle(buf_.lines(), buf_.lines());
    std::uint64_t* p = buf_.data();
    for (std::size_t i = 0; i < next.size(); ++i)
      p[i * kWordsPerLine] = next[i];
  }

  std::string_view kernel() const override { return "latency"; }
  std::uint64_t units_per_run() const override { return buf_.lines() * passes_; }

  double run(const std::atomic<bool>& stop, WorkCounters& c) override {
    const volatile std::uint64_t* p = buf_.data();
    const std::uint64_t total = units_per_run();
    std::uint64_t done = 0, at = at_;
    CountWriter count(c, c.lines_read);
    while (done < total) {
      const std::uint64_t n = std::min(kChunkLines, total - done);
      for (std::uint64_t k = 0; k < n; ++k)
        at = p[at * kWordsPerLine];
      count.retire(n);
      done += n;
      if (stop.load(std::memory_order_relaxed)) break;
    }
    at_ = at;  // the next run goes on along the cycle
    return static_cast<double>(done) / static_cast<double>(total);
  }

 private:
  Buffer buf_;
  std::uint64_t passes_;
  std::uint64_t at_ = 0;
};

// One proxy step: touch one line of the working set, then `alu` dependent ALU iterations.
inline std::uint64_t alu_work(std::uint64_t x, std::uint32_t alu) {
  for (std::uint32_t k = 0; k < alu; ++k) {
    x = x * 6364136223846793005ULL + 1442695040888963407ULL;
    asm volatile("" : "+r"(x));  // keep the dependent chain
  }
  return x;
}

class ProxyKernel : public BuiltinWorkload {
 public:
  ProxyKernel(double target_mbps, std::size_t working_set_kb, double runtime_ms)
      : buf_(working_set_kb * 1024) {
    cal_ = calibrate_proxy(target_mbps, static_cast<std::uint32_t>(working_set_kb));
    const double lines_per_s = target_mbps * kBytesPerMb / kLine;
    const double achievable_lines_per_s =
        1e9 / (cal_.ns_per_line + cal_.alu_per_line * cal_.ns_per_alu);
    units_ = std::max<std::uint64_t>(
        kChunkLines, static_cast<std::uint64_t>(std::min(lines_per_s, achievable_lines_per_s) *
                                                runtime_ms / 1e3));
  }

  std::string_view kernel() const override { return "proxy"; }
  std::uint64_t units_per_run() const override { return units_; }

  double run(const std::atomic<bool>& stop, WorkCounters& c) override {
    volatile std::uint64_t* p = buf_.data();
    const std::uint64_t lines = buf_.lines();
    std::uint64_t x = 1, done = 0, i = 0;
    CountWriter count(c, c.lines_read);
    while (done < units_) {
      const std::uint64_t n = std::min(kChunkLines, units_ - done);
      for (std::uint64_t k = 0; k < n; ++k) {
        x += p[i * kWordsPerLine];
        x = alu_work(x, cal_.alu_per_line);
        if (++i == lines) i = 0;
      }
      count.retire(n);
      done += n;
      if (stop.load(std::memory_order_relaxed)) break;
    }
    sink_ = x;
    return static_cast<double>(done) / static_cast<double>(units_);
  }

 private:
  Buffer buf_;
  ProxyCalibration cal_;
  std::uint64_t units_ = 0;
  volatile std::uint64_t sink_ = 0;
};

}  // namespace

std::vector<std::uint32_t> chase_cycle(std::size_t lines, std::uint64_t seed) {
  if (lines > std::size_t{1} << 32) throw RunError("pointer chase over more than 2^32 lines");
  std::vector<std::uint32_t> next(lines);
  for (std::size_t i = 0; i < lines; ++i)
    next[i] = static_cast<std::uint32_t>(i);
  // Sattolo's algorithm: j < i (never j == i) makes i -> next[i] a single cycle through all lines.
  std::mt19937_64 rng(seed);
  for (std::size_t i = lines; i-- > 1;) {
    const std::size_t j = std::uniform_int_distribution<std::size_t>(0, i - 1)(rng);
    std::swap(next[i], next[j]);
  }
  return next;
}

ProxyCalibration calibrate_proxy(double target_mbps, std::uint32_t working_set_kb) {
  static std::mutex mu;
  static std::map<std::pair<double, std::uint32_t>, ProxyCalibration> cache;
  std::lock_guard lock(mu);
  const auto key = std::make_pair(target_mbps, working_set_kb);
  if (auto it = cache.find(key); it != cache.end()) return it->second;

  Buffer buf(std::size_t{working_set_kb} * 1024);
  volatile std::uint64_t* p = buf.data();
  const std::uint64_t lines = buf.lines();
  std::uint64_t x = 1;
  std::vector<double> mem, alu;
  for (int trial = 0; trial < 7; ++trial) {
    const std::uint64_t n = std::max<std::uint64_t>(lines * 4, 200000);
    TimeNs t0 = now_ns();
    for (std::uint64_t i = 0, j = 0; i < n; ++i) {
      x += p[j * kWordsPerLine];
      if (++j == lines) j = 0;
    }
    TimeNs t1 = now_ns();
    mem.push_back(static_cast<double>(t1 - t0) / static_cast<double>(n));
    const std::uint32_t m = 2'000'000;
    t0 = now_ns();
    x = alu_work(x, m);
    t1 = now_ns();
    alu.push_back(static_cast<double>(t1 - t0) / m);
  }
  volatile std::uint64_t sink = x;
  (void)sink;
  ProxyCalibration c;
  c.ns_per_line = median(mem);
  c.ns_per_alu = median(alu);
  c.achievable_mbps = 1e9 / c.ns_per_line * kLine / kBytesPerMb;
  const double target_ns = 1e9 / (target_mbps * kBytesPerMb / kLine);
  if (target_ns > c.ns_per_line)
    c.alu_per_line = static_cast<std::uint32_t>((target_ns - c.ns_per_line) / c.ns_per_alu + 0.5);
  cache[key] = c;
  return c;
}

std::unique_ptr<BuiltinWorkload> make_builtin_workload(const WorkloadInfo& info) {
  if (info.is_command() || !info.doc.contains("hw"))
    throw InputError(info.origin, "/hw", "workload '" + info.name + "' has no built-in kernel");
  const auto& hw = info.doc.at("hw");
  const std::string kernel = hw.at("kernel").get<std::string>();
  const auto ws = hw.value("working_set_kb", std::size_t{2048});
  const auto passes = hw.value("passes", std::uint64_t{1});
  if (kernel == "bandwidth_read" || kernel == "bandwidth_write")
    return std::make_unique<BandwidthKernel>(kernel == "bandwidth_write", ws, passes);
  if (kernel == "latency") {
    if (ws * 1024 < 2 * kLine)
      throw InputError(info.origin, "/hw/working_set_kb", "the latency kernel needs two lines");
    return std::make_unique<LatencyKernel>(ws, passes);
  }
  if (kernel == "proxy") {
    if (!hw.contains("target_mbps"))
      throw InputError(info.origin, "/hw/target_mbps",
                       "a proxy workload needs target_mbps (the bandwidth to reach)");
    return std::make_unique<ProxyKernel>(hw.at("target_mbps").get<double>(), ws,
                                         hw.value("runtime_ms", 100.0));
  }
  throw InputError(info.origin, "/hw/kernel", "unknown kernel '" + kernel + "'");
}

}  // namespace rosguard::hw

// Work on the items of a large sweep spread over threads: building and checking its points,
// the keys of their baselines and co-runs. At 16 workers, these steps on one thread, before
// the first task could start, were a third of the wall time of a 10,000-point sweep.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace rosguard {

// Calls fn(i) for every i in [0, n) on up to `threads` threads (this one included), in chunks
// of consecutive items. When calls throw, the exception of the lowest such i is rethrown, as
// one thread would have met it first: calls for items after a failed one may be skipped, never
// those before it. `fn` must be safe to call from several threads at once.
template <typename Fn>
void parallel_for(std::size_t n, unsigned threads, const Fn& fn) {
  constexpr std::size_t kChunk = 64;
  std::atomic<std::size_t> next{0};
  std::mutex failed_mutex;
  std::size_t failed_at = n;  // the lowest item that failed
  std::exception_ptr failure;
  const auto work = [&] {
    for (std::size_t begin; (begin = next.fetch_add(kChunk)) < n;)
      for (std::size_t i = begin; i < std::min(begin + kChunk, n); ++i) {
        {
          const std::lock_guard<std::mutex> lock(failed_mutex);
          if (i > failed_at) return;
        }
        try {
          fn(i);
        } catch (...) {
          const std::lock_guard<std::mutex> lock(failed_mutex);
          if (i < failed_at) {
            failed_at = i;
            failure = std::current_exception();
          }
          return;
        }
      }
  };
  const std::size_t extra = std::min<std::size_t>(std::max(threads, 1U) - 1, n / kChunk);
  std::vector<std::thread> pool;
  for (std::size_t t = 0; t < extra; ++t)
    pool.emplace_back(work);
  work();
  for (auto& t : pool)
    t.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace rosguard

#pragma once
// Work shared among threads (daemon.merge_threads): a merge's recognition one N* at a time,
// its absorption one target place at a time, a restore's view summaries one place at a time.
// Each piece of work writes only what belongs to it, so the result is the same for any number
// of threads.

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <thread>
#include <vector>

namespace tsc {

/// Runs `work(g)` for every g < count on up to `threads` threads (the calling one among them),
/// each taking the next g left, so a thread that drew small pieces takes more of them.
/// Rethrows the exception of the lowest g that failed once all are done. Precondition: the
/// works write disjoint data.
template <typename Work>
void OnThreads(size_t count, int threads, const Work& work) {
  std::vector<std::exception_ptr> failed(count);
  std::atomic<size_t> next{0};
  const auto run = [&] {
    for (size_t g = next++; g < count; g = next++) {
      try {
        work(g);
      } catch (...) {
        failed[g] = std::current_exception();
      }
    }
  };
  std::vector<std::thread> helpers;
  const size_t workers = std::min(count, static_cast<size_t>(std::max(threads, 1)));
  for (size_t t = 1; t < workers; ++t) helpers.emplace_back(run);
  run();
  for (std::thread& t : helpers) t.join();
  for (const std::exception_ptr& e : failed) {
    if (e) std::rethrow_exception(e);
  }
}

/// Runs `work(first, end)` over [0, count) cut into blocks of `block` (the last may be
/// shorter), the blocks shared as OnThreads shares its pieces. Precondition: block ≥ 1.
template <typename Work>
void OnBlocks(size_t count, size_t block, int threads, const Work& work) {
  OnThreads((count + block - 1) / block, threads,
            [&](size_t b) { work(b * block, std::min(count, (b + 1) * block)); });
}

}  // namespace tsc

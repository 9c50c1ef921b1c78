#pragma once
// Small time and logging helpers shared by tscd's threads.

#include <chrono>
#include <cstdint>

namespace tsc {

/// Wall time in µs since the epoch (the `utime` of messages).
inline int64_t NowUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

/// Monotonic time in ms (heartbeats).
inline int64_t SteadyMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

/// Logs the first occurrences of a repeated problem, then one in every 100, so a flood of bad
/// frames or messages cannot drown the journal but is never silent. `occurrence` counts from 1.
inline bool ShouldLog(int64_t occurrence) { return occurrence <= 10 || occurrence % 100 == 0; }

}  // namespace tsc

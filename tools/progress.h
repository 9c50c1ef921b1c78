#pragma once
// A one-line progress bar on stderr, drawn only when stderr is a terminal, so logs and pipes
// stay clean.

#include <chrono>
#include <cstdint>
#include <cstdio>

namespace tsc {

struct ProgressCounts {
  int64_t detected_places = 0;
  int64_t learned_places = 0;
  int64_t recognitions = 0;
};

class ProgressBar {
 public:
  /// `total` frames; enabled when `out` is a terminal (isatty) unless `force_off`.
  explicit ProgressBar(int64_t total, std::FILE* out = stderr, bool force_off = false);
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  bool enabled() const { return enabled_; }
  /// `done` frames processed so far. Redraws at most ten times a second (and at the end).
  void Update(int64_t done, const ProgressCounts& counts);
  /// Clears the line; further updates are ignored.
  void Finish();

 private:
  using Clock = std::chrono::steady_clock;
  std::FILE* out_;
  int64_t total_;
  bool enabled_;
  Clock::time_point start_;
  Clock::time_point last_draw_;
};

}  // namespace tsc

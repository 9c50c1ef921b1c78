#pragma once
// Time as the drivers see it: a monotonic clock for pacing, watchdogs and backoff, the wall
// clock for frame stamps, and sleeping. Production code uses Clock::System(); tests inject a
// ManualClock whose sleeps return at once after moving time forward.

#include <atomic>
#include <cstdint>

#include "drivers/stop_signal.h"

namespace tsc {

class Clock {
 public:
  virtual ~Clock() = default;
  /// Monotonic time in microseconds (arbitrary origin).
  virtual int64_t SteadyMicros() const = 0;
  /// Wall time in microseconds since the Unix epoch.
  virtual int64_t WallMicros() const = 0;
  /// Blocks until SteadyMicros() ≥ steady_us (returns at once when already past).
  virtual void SleepUntil(int64_t steady_us) = 0;
  /// As SleepUntil, but returns early when `stop` is raised; false when it was (at once when
  /// it already is).
  virtual bool WaitUntil(int64_t steady_us, StopSignal& stop) {
    if (stop.raised()) return false;
    SleepUntil(steady_us);
    return !stop.raised();
  }

  /// The process-wide real clock (std::chrono::steady_clock / system_clock).
  static Clock& System();
};

/// A clock that moves only when told to (Advance) or when someone sleeps on it (SleepUntil
/// jumps to the wake-up time). Thread-safe. Wall time = steady time + a fixed epoch offset.
class ManualClock : public Clock {
 public:
  explicit ManualClock(int64_t start_us = 1'000'000, int64_t wall_offset_us = 1'700'000'000'000'000)
      : now_us_(start_us), wall_offset_us_(wall_offset_us) {}
  int64_t SteadyMicros() const override { return now_us_.load(); }
  int64_t WallMicros() const override { return now_us_.load() + wall_offset_us_; }
  void SleepUntil(int64_t steady_us) override;
  /// Moves time forward by dt_us ≥ 0.
  void Advance(int64_t dt_us) { now_us_.fetch_add(dt_us); }

 private:
  std::atomic<int64_t> now_us_;
  int64_t wall_offset_us_;
};

/// Paces a source to a rate: Wait() returns at most `fps` times per second, on a fixed grid
/// of due times (so delivery does not drift); after a stall of more than one period the
/// grid restarts from now instead of bursting to catch up. fps ≤ 0: never waits.
class Pacer {
 public:
  Pacer(double fps, Clock& clock);
  /// Blocks until the next due time; returns the steady time it returned at. With `stop`,
  /// returns early when it is raised (check stop->raised()).
  int64_t Wait(StopSignal* stop = nullptr);
  /// Forgets the grid: the next Wait() returns at once.
  void Reset() { started_ = false; }

 private:
  int64_t period_us_;
  Clock& clock_;
  bool started_ = false;
  int64_t due_us_ = 0;
};

}  // namespace tsc

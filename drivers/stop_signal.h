#pragma once
// A flag one thread raises to end another's waits at once (a camera asked to stop while it
// waits for its next frame; Clock::WaitUntil, CameraSource::Interrupt).

#include <chrono>
#include <condition_variable>
#include <mutex>

namespace tsc {

/// Raised by one thread to cut short another's waits (Clock::WaitUntil): a
/// camera asked to stop while it waits for its next frame. Thread-safe; stays raised.
class StopSignal {
 public:
  void Raise() {
    {
      std::lock_guard lock(mutex_);
      raised_ = true;
    }
    changed_.notify_all();
  }
  bool raised() const {
    std::lock_guard lock(mutex_);
    return raised_;
  }
  /// Blocks until `when` or Raise(); false when raised.
  bool WaitUntil(std::chrono::steady_clock::time_point when) {
    std::unique_lock lock(mutex_);
    return !changed_.wait_until(lock, when, [&] { return raised_; });
  }

 private:
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  bool raised_ = false;
};

}  // namespace tsc

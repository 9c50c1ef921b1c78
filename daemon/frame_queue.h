#pragma once
// The bounded queue between the camera thread and the pipeline worker. The camera never
// blocks: when the queue is full the oldest frame is dropped and counted (a robot would rather
// see now than catch up on the past).

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>

namespace tsc {

template <typename Frame>
class FrameQueue {
 public:
  /// Precondition: capacity ≥ 1.
  explicit FrameQueue(size_t capacity) : capacity_(capacity) {}

  /// Adds a frame, dropping the oldest when full. Returns false once closed.
  bool Push(Frame frame) {
    {
      std::lock_guard lock(mutex_);
      if (closed_) return false;
      if (frames_.size() >= capacity_) {
        frames_.pop_front();
        ++dropped_;
      }
      frames_.push_back(std::move(frame));
    }
    ready_.notify_one();
    return true;
  }

  /// Waits up to `timeout` for a frame. nullopt on timeout or when closed and empty.
  std::optional<Frame> Pop(std::chrono::milliseconds timeout) {
    std::unique_lock lock(mutex_);
    ready_.wait_for(lock, timeout, [&] { return closed_ || !frames_.empty(); });
    if (frames_.empty()) return std::nullopt;
    Frame f = std::move(frames_.front());
    frames_.pop_front();
    return f;
  }

  /// Wakes every waiter; later pushes are refused, frames already queued can still be popped.
  void Close() {
    {
      std::lock_guard lock(mutex_);
      closed_ = true;
    }
    ready_.notify_all();
  }

  bool closed() const {
    std::lock_guard lock(mutex_);
    return closed_;
  }
  int64_t dropped() const {
    std::lock_guard lock(mutex_);
    return dropped_;
  }
  /// Occupancy in [0, 1].
  /// Frames waiting now.
  size_t size() const {
    std::lock_guard lock(mutex_);
    return frames_.size();
  }
  double fill() const {
    std::lock_guard lock(mutex_);
    return static_cast<double>(frames_.size()) / static_cast<double>(capacity_);
  }

 private:
  const size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<Frame> frames_;
  bool closed_ = false;
  int64_t dropped_ = 0;
};

}  // namespace tsc

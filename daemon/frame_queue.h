#pragma once
// The bounded queue between the camera thread and the pipeline worker, in base points. A live
// camera never blocks: when the queue is full the oldest base point is dropped and counted (a
// robot would rather see now than catch up on the past). A replay (a recording read unpaced)
// waits for room instead, so it processes every frame whatever the machine's speed. A pan sweep
// delivers a base point as several views, the last one ending it; the queue gathers them and
// queues, hands out and drops only whole sweeps, so the pipeline never builds a base point from
// part of one (whose first view, which judges coherence, might be the part missing).

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>
#include <utility>
#include <vector>

namespace tsc {

template <typename View>
class FrameQueue {
 public:
  /// The views of one base point in the order taken; empty: the end of the stream.
  using BasePoint = std::vector<View>;

  /// `capacity`: whole base points waiting, besides the one being gathered and ends of the
  /// stream. Precondition: ≥ 1.
  explicit FrameQueue(size_t capacity) : capacity_(capacity) {}

  /// Adds a view to the base point being gathered. The view that ends it queues the whole
  /// base point; when the queue is full it drops the oldest waiting one (every view of it,
  /// counted once), or with `wait_for_room` waits until the worker takes one. Returns false
  /// once closed (a base point still waiting for room then is discarded, not counted).
  bool Push(View view, bool ends_base_point, bool wait_for_room = false) {
    {
      std::unique_lock lock(mutex_);
      if (closed_) return false;
      gathering_.push_back(std::move(view));
      if (!ends_base_point) return true;
      if (wait_for_room) {
        room_.wait(lock, [&] { return closed_ || Waiting() < capacity_; });
        if (closed_) return false;
      }
      Enqueue(std::exchange(gathering_, {}));
    }
    ready_.notify_one();
    return true;
  }

  /// Queues the end of the stream (an empty base point) after what waits; it takes no room of
  /// the capacity (nothing waiting is dropped for it) and is never dropped. The views of a
  /// base point still being gathered (the source ended or stopped mid-sweep) are discarded,
  /// not counted: nothing fell behind. Returns false once closed.
  bool PushEnd() {
    {
      std::lock_guard lock(mutex_);
      if (closed_) return false;
      gathering_.clear();
      waiting_.emplace_back();
    }
    ready_.notify_one();
    return true;
  }

  /// Waits up to `timeout` for a whole base point. nullopt on timeout, after Wake(), or when
  /// closed and empty.
  std::optional<BasePoint> Pop(std::chrono::milliseconds timeout) {
    std::unique_lock lock(mutex_);
    ready_.wait_for(lock, timeout, [&] { return closed_ || woken_ || !waiting_.empty(); });
    woken_ = false;
    if (waiting_.empty()) return std::nullopt;
    BasePoint b = std::move(waiting_.front());
    waiting_.pop_front();
    lock.unlock();
    room_.notify_one();
    return b;
  }

  /// Makes the current (or else the next) Pop return at once, with nullopt when nothing
  /// waits: the worker has something else to do.
  void Wake() {
    {
      std::lock_guard lock(mutex_);
      woken_ = true;
    }
    ready_.notify_all();
  }

  /// Wakes every waiter; later pushes are refused, base points already queued can still be
  /// popped.
  void Close() {
    {
      std::lock_guard lock(mutex_);
      closed_ = true;
    }
    ready_.notify_all();
    room_.notify_all();
  }

  bool closed() const {
    std::lock_guard lock(mutex_);
    return closed_;
  }
  /// Base points dropped because the queue was full (a sweep of K views counts once).
  int64_t dropped() const {
    std::lock_guard lock(mutex_);
    return dropped_;
  }
  /// Base points waiting now (the one being gathered is not counted).
  size_t size() const {
    std::lock_guard lock(mutex_);
    return Waiting();
  }
  /// Occupancy in [0, 1].
  double fill() const {
    std::lock_guard lock(mutex_);
    return static_cast<double>(Waiting()) / static_cast<double>(capacity_);
  }

 private:
  // Base points waiting, not counting ends of the stream. mutex_ held.
  size_t Waiting() const {
    return static_cast<size_t>(std::count_if(waiting_.begin(), waiting_.end(),
                                             [](const BasePoint& w) { return !w.empty(); }));
  }

  void Enqueue(BasePoint b) {  // mutex_ held
    if (Waiting() >= capacity_) {
      // The oldest base point goes, every view of it; an end of the stream is never dropped.
      waiting_.erase(std::find_if(waiting_.begin(), waiting_.end(),
                                  [](const BasePoint& w) { return !w.empty(); }));
      ++dropped_;
    }
    waiting_.push_back(std::move(b));
  }

  const size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable ready_;
  std::condition_variable room_;  // a waiting push: the worker took a base point
  std::deque<BasePoint> waiting_;
  BasePoint gathering_;  // views of the base point under way
  bool closed_ = false;
  bool woken_ = false;
  int64_t dropped_ = 0;
};

}  // namespace tsc

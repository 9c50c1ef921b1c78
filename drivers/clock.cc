#include "drivers/clock.h"

#include <chrono>
#include <cmath>
#include <thread>

namespace tsc {
namespace {

class SystemClock : public Clock {
 public:
  int64_t SteadyMicros() const override {
    return std::chrono::duration_cast<std::chrono::microseconds>(
               std::chrono::steady_clock::now().time_since_epoch())
        .count();
  }
  int64_t WallMicros() const override {
    return std::chrono::duration_cast<std::chrono::microseconds>(
               std::chrono::system_clock::now().time_since_epoch())
        .count();
  }
  void SleepUntil(int64_t steady_us) override { std::this_thread::sleep_until(When(steady_us)); }
  bool WaitUntil(int64_t steady_us, StopSignal& stop) override {
    return stop.WaitUntil(When(steady_us));
  }

 private:
  static std::chrono::steady_clock::time_point When(int64_t steady_us) {
    return std::chrono::steady_clock::time_point(std::chrono::microseconds(steady_us));
  }
};

}  // namespace

Clock& Clock::System() {
  static SystemClock clock;
  return clock;
}

void ManualClock::SleepUntil(int64_t steady_us) {
  int64_t now = now_us_.load();
  while (now < steady_us && !now_us_.compare_exchange_weak(now, steady_us)) {
  }
}

Pacer::Pacer(double fps, Clock& clock)
    : period_us_(fps > 0.0 ? static_cast<int64_t>(std::llround(1e6 / fps)) : 0), clock_(clock) {}

int64_t Pacer::Wait(StopSignal* stop) {
  const int64_t now = clock_.SteadyMicros();
  if (period_us_ <= 0) return now;
  if (!started_ || now > due_us_ + period_us_) {
    started_ = true;
    due_us_ = now;
    return now;
  }
  due_us_ += period_us_;
  if (stop != nullptr) {
    clock_.WaitUntil(due_us_, *stop);
  } else {
    clock_.SleepUntil(due_us_);
  }
  return clock_.SteadyMicros();
}

}  // namespace tsc

#include "drivers/base/sim_base.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace tsc {
namespace {

double WrapAngle(double a) { return std::remainder(a, 2.0 * std::numbers::pi); }  // [−π, π]

double Clamp(double v, double limit) {
  if (!std::isfinite(v)) return 0.0;
  return std::clamp(v, -limit, limit);
}

}  // namespace

void SimBaseOptions::Validate() const {
  if (!(max_linear_mps > 0.0 && max_linear_mps <= 20.0)) {
    throw std::invalid_argument("sim base: max_linear_mps " + std::to_string(max_linear_mps) +
                                " must be in (0, 20]");
  }
  if (!(max_angular_radps > 0.0 && max_angular_radps <= 20.0)) {
    throw std::invalid_argument("sim base: max_angular_radps " + std::to_string(max_angular_radps) +
                                " must be in (0, 20]");
  }
  if (!(watchdog_s > 0.0 && watchdog_s <= 60.0)) {
    throw std::invalid_argument("sim base: watchdog_s " + std::to_string(watchdog_s) +
                                " must be in (0, 60]");
  }
  if (!std::isfinite(start_x_m) || !std::isfinite(start_y_m) || !std::isfinite(start_heading_rad)) {
    throw std::invalid_argument("sim base: start pose must be finite");
  }
}

SimBase::SimBase(const SimBaseOptions& options, Clock& clock)
    : options_((options.Validate(), options)),
      clock_(clock),
      watchdog_us_(static_cast<int64_t>(std::llround(options.watchdog_s * 1e6))),
      integrated_us_(clock.SteadyMicros()),
      last_command_us_(integrated_us_) {
  odometry_.x = options.start_x_m;
  odometry_.y = options.start_y_m;
  odometry_.heading = WrapAngle(options.start_heading_rad);
}

void SimBase::AdvanceTo(int64_t now_us) const {
  if (now_us <= integrated_us_) return;
  const bool moving = odometry_.linear_mps != 0.0 || odometry_.angular_radps != 0.0;
  const int64_t deadline = last_command_us_ + watchdog_us_;
  const int64_t until = moving ? std::min(now_us, std::max(deadline, integrated_us_)) : now_us;
  if (moving) {
    const double dt = static_cast<double>(until - integrated_us_) * 1e-6;
    const double v = odometry_.linear_mps, w = odometry_.angular_radps;
    const double h = odometry_.heading;
    if (std::abs(w) < 1e-9) {
      odometry_.x += v * std::cos(h) * dt;
      odometry_.y += v * std::sin(h) * dt;
    } else {
      const double h1 = h + w * dt;
      odometry_.x += v / w * (std::sin(h1) - std::sin(h));
      odometry_.y -= v / w * (std::cos(h1) - std::cos(h));
      odometry_.heading = WrapAngle(h1);
    }
    if (until < now_us) {  // the watchdog fired at `until`
      odometry_.linear_mps = 0.0;
      odometry_.angular_radps = 0.0;
      odometry_.stopped = true;
      odometry_.fault = "watchdog";
    }
  }
  integrated_us_ = now_us;
}

void SimBase::Command(const MotorCommand& command) {
  std::lock_guard<std::mutex> lock(mutex_);
  const int64_t now = clock_.SteadyMicros();
  AdvanceTo(now);
  last_command_us_ = now;
  if (command.estop) {
    estop_latched_ = true;
    odometry_.linear_mps = 0.0;
    odometry_.angular_radps = 0.0;
    odometry_.stopped = true;
    odometry_.fault = "estop";
    return;
  }
  estop_latched_ = false;
  odometry_.linear_mps = Clamp(command.linear_mps, options_.max_linear_mps);
  odometry_.angular_radps = Clamp(command.angular_radps, options_.max_angular_radps);
  odometry_.stopped = odometry_.linear_mps == 0.0 && odometry_.angular_radps == 0.0;
  odometry_.fault.clear();
}

void SimBase::Stop() {
  std::lock_guard<std::mutex> lock(mutex_);
  const int64_t now = clock_.SteadyMicros();
  AdvanceTo(now);
  odometry_.linear_mps = 0.0;
  odometry_.angular_radps = 0.0;
  odometry_.stopped = true;
  if (!estop_latched_) odometry_.fault.clear();
}

Odometry SimBase::state() const {
  std::lock_guard<std::mutex> lock(mutex_);
  const int64_t now = clock_.SteadyMicros();
  AdvanceTo(now);
  Odometry out = odometry_;
  out.utime = clock_.WallMicros();
  return out;
}

}  // namespace tsc

#include "drivers/motor/jaguar_drive.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace tsc {
namespace {

void Check(bool ok, const std::string& field, double value, const std::string& range) {
  if (!ok) {
    throw std::invalid_argument("jaguar: " + field + " " + std::to_string(value) + " must be " +
                                range);
  }
}

double Clamp(double v, double limit) {
  if (!std::isfinite(v)) return 0.0;
  return std::clamp(v, -limit, limit);
}

}  // namespace

void JaguarOptions::Validate() const {
  if (host.empty()) throw std::invalid_argument("jaguar: host is empty");
  Check(port > 0 && port <= 65535, "port", port, "in [1, 65535]");
  Check(max_linear_mps > 0.0 && max_linear_mps <= 20.0, "max_linear_mps", max_linear_mps,
        "in (0, 20]");
  Check(max_angular_radps > 0.0 && max_angular_radps <= 20.0, "max_angular_radps",
        max_angular_radps, "in (0, 20]");
  Check(watchdog_s > 0.0 && watchdog_s <= 60.0, "watchdog_s", watchdog_s, "in (0, 60]");
  Check(link_timeout_s > 0.0 && link_timeout_s <= 60.0, "link_timeout_s", link_timeout_s,
        "in (0, 60]");
  Check(send_period_s > 0.0 && send_period_s <= 0.2, "send_period_s", send_period_s,
        "in (0, 0.2] (the ASCII board wants a PING every 200 ms)");
  Check(full_power_mps > 0.0 && full_power_mps <= 20.0, "full_power_mps", full_power_mps,
        "in (0, 20]");
  Check(track_width_m > 0.0 && track_width_m <= 5.0, "track_width_m", track_width_m, "in (0, 5]");
  Check(counts_per_metre > 0.0 && counts_per_metre <= 1e7, "counts_per_metre", counts_per_metre,
        "in (0, 1e7]");
  for (const auto& [name, sign] : {std::pair{"left_sign", left_sign},
                                   {"right_sign", right_sign},
                                   {"forward_sign", forward_sign},
                                   {"turn_sign", turn_sign}}) {
    Check(sign == 1 || sign == -1, name, sign, "1 or -1");
  }
  if (!std::isfinite(start_x_m) || !std::isfinite(start_y_m) || !std::isfinite(start_heading_rad)) {
    throw std::invalid_argument("jaguar: start pose must be finite");
  }
}

CommandGate::CommandGate(const JaguarOptions& options)
    : max_linear_(options.max_linear_mps),
      max_angular_(options.max_angular_radps),
      watchdog_us_(static_cast<int64_t>(std::llround(options.watchdog_s * 1e6))) {
  demand_.reason = "stopped";
}

void CommandGate::Command(const MotorCommand& c, int64_t now_us) {
  last_command_us_ = now_us;
  halted_ = false;
  demand_ = DriveDemand{};
  if (c.estop) {
    demand_.estop = true;
    demand_.reason = "estop";
    return;
  }
  demand_.linear_mps = Clamp(c.linear_mps, max_linear_);
  demand_.angular_radps = Clamp(c.angular_radps, max_angular_);
  demand_.flipper_front = Clamp(c.flipper_front, 1.0);
  demand_.flipper_rear = Clamp(c.flipper_rear, 1.0);
}

void CommandGate::Halt(const std::string& reason) {
  halted_ = true;
  const bool estop = demand_.estop;  // a latched e-stop stays latched
  demand_ = DriveDemand{};
  demand_.estop = estop;
  demand_.reason = estop ? "estop" : reason;
}

DriveDemand CommandGate::At(int64_t now_us) const {
  if (halted_ || demand_.estop) return demand_;
  if (now_us >= watchdog_deadline_us()) {
    DriveDemand stop;
    stop.reason = "watchdog";
    return stop;
  }
  return demand_;
}

SidePowers MixSides(double v, double w, double full_power_mps, double track_width_m) {
  double left = (v - w * track_width_m / 2.0) / full_power_mps;
  double right = (v + w * track_width_m / 2.0) / full_power_mps;
  const double m = std::max(std::abs(left), std::abs(right));
  if (m > 1.0) left /= m, right /= m;
  return {left, right};
}

DifferentialOdometry::DifferentialOdometry(const JaguarOptions& options)
    : counts_per_metre_(options.counts_per_metre),
      track_width_m_(options.track_width_m),
      x_(options.start_x_m),
      y_(options.start_y_m),
      heading_(std::remainder(options.start_heading_rad, 2.0 * std::numbers::pi)) {}

void DifferentialOdometry::Update(int64_t left, int64_t right, int64_t t_us) {
  if (!started_) {
    started_ = true;
    last_left_ = left, last_right_ = right, last_t_us_ = t_us;
    return;
  }
  const double dl = static_cast<double>(left - last_left_) / counts_per_metre_;
  const double dr = static_cast<double>(right - last_right_) / counts_per_metre_;
  const double ds = (dl + dr) / 2.0, dth = (dr - dl) / track_width_m_;
  const double mid = heading_ + dth / 2.0;
  x_ += ds * std::cos(mid);
  y_ += ds * std::sin(mid);
  heading_ = std::remainder(heading_ + dth, 2.0 * std::numbers::pi);
  const double dt = static_cast<double>(t_us - last_t_us_) * 1e-6;
  if (dt > 0.0) linear_ = ds / dt, angular_ = dth / dt;
  last_left_ = left, last_right_ = right, last_t_us_ = t_us;
}

Odometry SharedState(const DifferentialOdometry& odometry, const DriveDemand& sent, bool link_ok,
                     double battery_volts, const std::vector<double>& temperatures_c,
                     int64_t utime) {
  Odometry o;
  o.utime = utime;
  o.x = odometry.x();
  o.y = odometry.y();
  o.heading = odometry.heading();
  o.linear_mps = odometry.linear_mps();
  o.angular_radps = odometry.angular_radps();
  o.stopped = !sent.moving() || !link_ok;
  o.battery_volts = battery_volts;
  o.temperatures_c = temperatures_c;
  o.link_ok = link_ok;
  return o;
}

}  // namespace tsc

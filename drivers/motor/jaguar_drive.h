#pragma once
// What both Jaguar drivers share, as pure computation: their options, the command gate (speed
// limits, the 0.5 s command watchdog, the latching e-stop), the mix of (v, ω) into side powers,
// and differential odometry from the two sides' encoders.

#include <cstdint>
#include <string>
#include <vector>

#include "drivers/base/motor_base.h"

namespace tsc {

/// Options of the Jaguar drivers. Every fact the facts file marks uncertain (counts per metre,
/// sign of the sides, speed at full power) is a field here, calibrated per robot.
struct JaguarOptions {
  std::string host = "192.168.0.60";  ///< the board's IPv4 address
  int port = 10001;                   ///< UDP (V2/V4) or TCP (4x4/V6) port
  double max_linear_mps = 1.0;        ///< |forward speed| limit, m/s (commands are clamped)
  double max_angular_radps = 1.5;     ///< |turn rate| limit, rad/s
  double watchdog_s = 0.5;            ///< no command for this long → motors stop
  double link_timeout_s = 2.0;        ///< no frame/line from the board this long → link lost
  double send_period_s = 0.1;         ///< commands are repeated this often (lost datagrams)
  double full_power_mps = 1.5;        ///< side speed at full power (PWM ±16383, ±1000), m/s
  double track_width_m = 0.52;        ///< distance between the left and right tracks/wheels
  double counts_per_metre = 640.0;    ///< encoder counts per metre of side travel
  int left_sign = 1;                  ///< sign of the left side's power and encoder counts
  int right_sign = -1;                ///< sign of the right side's (sides are mirrored)
  int forward_sign = 1;               ///< V2: sign of ch3 PWM − 16384 for forward
  int turn_sign = 1;                  ///< V2: sign of ch4 PWM − 16384 for counter-clockwise
  double start_x_m = 0.0;             ///< odometry origin in the world frame
  double start_y_m = 0.0;
  double start_heading_rad = 0.0;
  /// Throws std::invalid_argument naming the bad field.
  void Validate() const;
};

/// What the motors should do now.
struct DriveDemand {
  double linear_mps = 0.0;
  double angular_radps = 0.0;
  double flipper_front = 0.0;
  double flipper_rear = 0.0;
  bool estop = false;
  std::string reason;  ///< "" moving or idle; "watchdog" | "estop" | "link lost" | "stopped"
  bool moving() const {
    return linear_mps != 0.0 || angular_radps != 0.0 || flipper_front != 0.0 || flipper_rear != 0.0;
  }
  bool operator==(const DriveDemand&) const = default;
};

/// Speed limits, command watchdog and e-stop latch. Not thread-safe (the drivers lock).
class CommandGate {
 public:
  explicit CommandGate(const JaguarOptions& options);
  /// A command at steady time `now_us`: clamped to the limits (non-finite → 0); estop latches
  /// until a command with estop = false arrives.
  void Command(const MotorCommand& command, int64_t now_us);
  /// Stops until the next command; `reason` is reported meanwhile ("stopped", "link lost").
  void Halt(const std::string& reason);
  /// The demand at `now_us`: zero after the watchdog deadline.
  DriveDemand At(int64_t now_us) const;
  int64_t watchdog_deadline_us() const { return last_command_us_ + watchdog_us_; }

 private:
  double max_linear_, max_angular_;
  int64_t watchdog_us_;
  DriveDemand demand_;
  int64_t last_command_us_ = INT64_MIN / 2;
  bool halted_ = true;
};

/// Side speeds of a differential (skid-steer) base for (v, ω), as fractions of full power in
/// [−1, 1]; when one side would exceed full power both are scaled down (the turn radius is
/// kept).
struct SidePowers {
  double left = 0.0, right = 0.0;
};
SidePowers MixSides(double linear_mps, double angular_radps, double full_power_mps,
                    double track_width_m);

/// Pose from the two sides' unwrapped encoder counts (midpoint integration of each step).
class DifferentialOdometry {
 public:
  DifferentialOdometry(const JaguarOptions& options);
  /// Counts already signed so that forward is positive on both sides, at steady time t_us.
  /// The first reading is the origin.
  void Update(int64_t left, int64_t right, int64_t t_us);
  /// Forgets the last reading (after a reconnection the board's counters may restart); the
  /// pose is kept.
  void Restart() { started_ = false; }
  double x() const { return x_; }
  double y() const { return y_; }
  double heading() const { return heading_; }
  double linear_mps() const { return linear_; }
  double angular_radps() const { return angular_; }

 private:
  double counts_per_metre_, track_width_m_;
  bool started_ = false;
  int64_t last_left_ = 0, last_right_ = 0, last_t_us_ = 0;
  double x_, y_, heading_;
  double linear_ = 0.0, angular_ = 0.0;
};

/// What both drivers report alike: pose and velocities from `odometry`, stopped unless the
/// last command sent (`sent`) moves the base over a working link, the link state and the
/// board's battery and temperatures. The fault and the tick counts are each driver's own.
Odometry SharedState(const DifferentialOdometry& odometry, const DriveDemand& sent, bool link_ok,
                     double battery_volts, const std::vector<double>& temperatures_c,
                     int64_t utime);

}  // namespace tsc

#pragma once
// The motor channel of the hardware abstraction layer: a base that takes velocity commands
// and reports odometry. The simulated base integrates commands into the pose the simulated
// camera renders from; the Jaguar drivers (V2/V4 binary over UDP, 4x4/V6 ASCII over TCP)
// implement the same interface.

#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace tsc {

class MotorError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct MotorCommand {
  double linear_mps = 0.0;     ///< forward, m/s
  double angular_radps = 0.0;  ///< counter-clockwise, rad/s
  bool estop = false;
  double flipper_front = 0.0;  ///< flipper (arm) power in [−1, 1]; Jaguar V2/V4 only
  double flipper_rear = 0.0;
};

struct Odometry {
  int64_t utime = 0;
  double x = 0.0;  ///< metres
  double y = 0.0;
  double heading = 0.0;  ///< radians counter-clockwise from +x
  double linear_mps = 0.0;
  double angular_radps = 0.0;
  bool stopped = true;
  std::string fault;  ///< "" or why the motors are stopped
  // Health, when the base reports it (a real board); a simulated base leaves the defaults.
  int64_t left_ticks = 0;  ///< unwrapped encoder counts
  int64_t right_ticks = 0;
  double battery_volts = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> temperatures_c;
  bool link_ok = true;  ///< the board answers
};

class MotorBase {
 public:
  virtual ~MotorBase() = default;
  /// Sends a command; the base stops on its own when commands stop coming (watchdog 0.5 s).
  virtual void Command(const MotorCommand& command) = 0;
  /// Stops the motors now.
  virtual void Stop() = 0;
  /// Latest odometry.
  virtual Odometry state() const = 0;
};

}  // namespace tsc

#pragma once
// Which motor channel a robot drives (drivers/motor/make_motor.h chooses and opens it). Plain
// values: the configuration table (settings/settings.h) names and checks them as motor.*.

#include <string>

namespace tsc {

/// The motor channel (drivers/base, drivers/motor). Facts the protocol sources leave uncertain
/// (counts per metre, signs of the sides, speed at full power) are calibration keys.
struct MotorOptions {
  /// "sim": the simulated base (with camera.source = sim and sim.drive = commands);
  /// "jaguar-v2": Jaguar V2/V4 board, binary protocol over UDP; "jaguar-ascii": Jaguar
  /// 4x4/V6 boards, ASCII protocol over TCP.
  std::string driver = "sim";
  std::string address = "192.168.0.60";  ///< the board's IPv4 address
  int port = 10001;
  double max_linear_mps = 1.0;     ///< |forward speed| limit, m/s
  double max_angular_radps = 1.5;  ///< |turn rate| limit, rad/s
  double watchdog_s = 0.5;         ///< no command this long → stop
  double link_timeout_s = 2.0;     ///< board silent this long → link lost, stop
  double full_power_mps = 1.5;     ///< side speed at full power
  double track_width_m = 0.52;
  double counts_per_metre = 640.0;
  int left_sign = 1;  ///< sign of the left side's power and encoder counts
  int right_sign = -1;
  int forward_sign = 1;  ///< V2: ch3 PWM above 16384 drives forward (1) or backward (-1)
  int turn_sign = 1;     ///< V2: ch4 PWM above 16384 turns counter-clockwise (1) or not (-1)
};

}  // namespace tsc

#pragma once
// The simulated base: a unicycle that integrates velocity commands into a planar pose, with
// the motor channel's safety behaviour (speed limits, command watchdog, latching estop). The
// simulated camera renders from its pose.

#include <cstdint>
#include <mutex>

#include "drivers/base/motor_base.h"
#include "drivers/clock.h"

namespace tsc {

struct SimBaseOptions {
  double max_linear_mps = 1.0;     ///< |forward speed| limit, m/s (commands are clamped)
  double max_angular_radps = 1.5;  ///< |turn rate| limit, rad/s (commands are clamped)
  double watchdog_s = 0.5;         ///< no command for this long → motors stop
  double start_x_m = 0.0;          ///< initial pose, world frame
  double start_y_m = 0.0;
  double start_heading_rad = 0.0;  ///< counter-clockwise from +x
  /// Throws std::invalid_argument naming the bad field.
  void Validate() const;
};

/// Thread-safe: Command()/Stop() on one thread and state() on others. The pose is advanced
/// lazily to the clock's time on every call, integrating the unicycle exactly for the
/// constant command in force (dx = v/ω·(sin(θ+ωt) − sin θ), ...).
class SimBase : public MotorBase {
 public:
  /// `clock` must outlive the base. Throws std::invalid_argument for bad options.
  explicit SimBase(const SimBaseOptions& options, Clock& clock = Clock::System());

  /// Applies a command (clamped to the limits) from now on and feeds the watchdog.
  /// estop = true stops the base and latches fault "estop": velocities are ignored until a
  /// command with estop = false arrives. Non-finite velocities count as zero.
  void Command(const MotorCommand& command) override;
  /// Stops now (no fault); the next command moves again.
  void Stop() override;
  /// Pose and velocities at the clock's time. fault: "" | "watchdog" | "estop".
  Odometry state() const override;

  const SimBaseOptions& options() const { return options_; }

 private:
  /// Integrates up to `now_us`, stopping at the watchdog deadline. Caller holds mutex_.
  void AdvanceTo(int64_t now_us) const;

  SimBaseOptions options_;
  Clock& clock_;
  int64_t watchdog_us_;
  mutable std::mutex mutex_;
  mutable Odometry odometry_;
  mutable int64_t integrated_us_;  ///< steady time odometry_ is valid at
  int64_t last_command_us_;        ///< steady time of the last command
  bool estop_latched_ = false;
};

}  // namespace tsc

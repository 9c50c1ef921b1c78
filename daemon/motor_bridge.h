#pragma once
// The robot's motor channel on LCM (README, "Running on a robot"): commands from
// JAGUAR_CMD_<robot> go to the base, its odometry goes out on JAGUAR_STATE_<robot> ten times a
// second. Event loop thread only.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "daemon/daemon_counters.h"
#include "daemon/team_bus.h"
#include "drivers/base/motor_base.h"

namespace boost::asio {
class io_context;
}

namespace tsc {

class MotorBridge {
 public:
  /// Bridges `base` (robot `robot`) to `bus`, with timers on `io`; `counters` count malformed
  /// commands.
  MotorBridge(MotorBase& base, uint32_t robot, TeamBus& bus, boost::asio::io_context& io,
              DaemonCounters& counters);
  ~MotorBridge();
  MotorBridge(const MotorBridge&) = delete;
  MotorBridge& operator=(const MotorBridge&) = delete;

  /// Takes commands from JAGUAR_CMD_<robot> (before the loop runs).
  void Subscribe();
  /// Publishes the odometry now and every 100 ms.
  void Start();
  /// Stops the motors; commands are ignored from now on.
  void StopMotors();
  /// Ends the odometry timer (shutdown).
  void Cancel();

 private:
  void OnTimer();
  void OnCommand(const std::string& channel, const uint8_t* data, size_t size);

  MotorBase& base_;
  const uint32_t robot_;
  TeamBus& bus_;
  DaemonCounters& counters_;
  struct Timer;  // the Asio timer, kept out of this header
  std::unique_ptr<Timer> timer_;
  bool stopped_ = false;
  bool cancelled_ = false;
};

}  // namespace tsc

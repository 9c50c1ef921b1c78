#pragma once
// The Jaguar 4x4 (2014) / V4 / V6 motor boards over TCP (ASCII protocol,
// jaguar_ascii_protocol.h) as a MotorBase: (v, ω) → `MMW !M <L> <R>` wheel powers, PING every
// send_period_s (≤ 200 ms); odometry from the front wheel board's encoder counts (`MM0 C=`),
// battery (`V=`), temperatures (`T=`), faults (`FF=`) and the IMU line.
//
// Safety: on connecting it sends `!M 0 0` then `!EX` (the boards may remember the last command)
// and releases with `!MG` only before the first motion; it stops (`!M 0 0`) when no command came
// for watchdog_s, on Stop() and in its destructor; `!EX` on e-stop. A connection that breaks or
// stays silent for link_timeout_s is closed and opened again with backoff (0.2 s doubling to 2 s).

#include <atomic>
#include <cstdint>
#include <mutex>
#include <optional>
#include <thread>

#include "drivers/base/motor_base.h"
#include "drivers/clock.h"
#include "drivers/motor/jaguar_ascii_protocol.h"
#include "drivers/motor/jaguar_drive.h"
#include "drivers/motor/jaguar_v2_base.h"

namespace tsc {

class JaguarAsciiBase : public MotorBase {
 public:
  /// Starts the link thread, which connects to options.host:port (and keeps reconnecting).
  /// Throws std::invalid_argument for bad options.
  /// `clock` (the system's by default; a test injects a ManualClock) times the command
  /// watchdog, the resends and the link timeout; it must outlive the driver.
  explicit JaguarAsciiBase(const JaguarOptions& options, Clock& clock = Clock::System());
  /// Stops the motors and closes the connection.
  ~JaguarAsciiBase() override;
  JaguarAsciiBase(const JaguarAsciiBase&) = delete;
  JaguarAsciiBase& operator=(const JaguarAsciiBase&) = delete;

  void Command(const MotorCommand& command) override;
  void Stop() override;
  Odometry state() const override;
  JaguarLinkCounters counters() const;
  /// The last IMU line, when one came.
  std::optional<jaguar_ascii::ImuLine> imu() const;

 private:
  void Run();
  bool Connect();
  void Disconnect(bool lost);
  void Receive(int64_t now_us);
  void Handle(const std::string& line, int64_t now_us);
  /// Caller holds mutex_.
  void SendDemand(const DriveDemand& demand);
  bool SendLine(const std::string& line);

  JaguarOptions options_;
  Clock& clock_;
  int fd_ = -1;
  int wake_[2] = {-1, -1};
  std::atomic<bool> quit_{false};

  mutable std::mutex mutex_;
  CommandGate gate_;
  DriveDemand sent_;
  bool released_ = false;  // `!MG` sent since the last connect / e-stop
  int64_t next_send_us_ = 0;
  DifferentialOdometry odometry_;
  jaguar_ascii::LineSplitter lines_;
  JaguarLinkCounters counters_;
  bool link_ok_ = false;
  int64_t last_rx_us_ = 0;
  int64_t left_ticks_ = 0, right_ticks_ = 0;
  double battery_volts_;
  std::vector<double> temperatures_c_;
  std::string board_fault_;
  std::optional<jaguar_ascii::ImuLine> imu_;
  std::thread thread_;
};

}  // namespace tsc

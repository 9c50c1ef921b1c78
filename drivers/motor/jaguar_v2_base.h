#pragma once
// The Jaguar V2 / tracked V4 board over UDP (binary protocol, jaguar_v2_protocol.h) as a
// MotorBase: (v, ω) → PWM on ch3 (forward power) and ch4 (turn power), flippers on ch0/ch1;
// odometry from the 0x7C track encoders, battery and motor temperatures from its analog inputs.
//
// Safety: the board has no documented watchdog, so this driver is the watchdog. It stops the
// motors (PWM 16384 on ch0/1/3/4) when no command came for watchdog_s, when the board was silent
// for link_timeout_s (link lost), on Stop(), on e-stop and in its destructor.

#include <atomic>
#include <cstdint>
#include <mutex>
#include <thread>

#include "drivers/base/motor_base.h"
#include "drivers/clock.h"
#include "drivers/motor/jaguar_drive.h"
#include "drivers/motor/jaguar_v2_protocol.h"

namespace tsc {

/// Counters of the link, for status lines and tests.
struct JaguarLinkCounters {
  int64_t frames_received = 0;  ///< valid frames (or reply lines) from the board
  int64_t frames_rejected = 0;  ///< corrupted frames / malformed lines, dropped
  int64_t commands_sent = 0;    ///< PWM frames / power lines sent
  int64_t stops_sent = 0;       ///< of which stops
  int64_t links_lost = 0;       ///< times the board went silent or the connection broke
  int64_t connects = 0;         ///< times the link came (back) up
};

class JaguarV2Base : public MotorBase {
 public:
  /// Opens a UDP socket to options.host:port and starts the link thread, which sends the ACK
  /// that makes the board stream its sensor frames. Throws std::invalid_argument for bad
  /// options, MotorError when no socket can be opened.
  /// `clock` (the system's by default; a test injects a ManualClock) times the command
  /// watchdog, the resends and the link timeout; it must outlive the driver.
  explicit JaguarV2Base(const JaguarOptions& options, Clock& clock = Clock::System());
  /// Stops the motors (three all-stop frames) and closes the link.
  ~JaguarV2Base() override;
  JaguarV2Base(const JaguarV2Base&) = delete;
  JaguarV2Base& operator=(const JaguarV2Base&) = delete;

  void Command(const MotorCommand& command) override;
  /// Sends the all-stop frame now.
  void Stop() override;
  Odometry state() const override;
  JaguarLinkCounters counters() const;
  jaguar_v2::DecodeCounters decode_counters() const;

 private:
  void Run();
  void Receive(int64_t now_us);
  void Handle(const jaguar_v2::Frame& frame, int64_t now_us);
  /// Sends the PWM frame for `demand`. Caller holds mutex_.
  void SendDemand(const DriveDemand& demand);
  void SendBytes(const std::vector<uint8_t>& bytes);

  JaguarOptions options_;
  Clock& clock_;
  int fd_ = -1;
  int wake_[2] = {-1, -1};  // pipe: wakes the link thread on a new command and at shutdown
  std::atomic<bool> quit_{false};

  mutable std::mutex mutex_;
  CommandGate gate_;
  DriveDemand sent_;  // what the last PWM frame said
  int64_t next_send_us_ = 0;
  DifferentialOdometry odometry_;
  jaguar_v2::EncoderUnwrap left_, right_;
  jaguar_v2::DecodeCounters decode_;
  JaguarLinkCounters counters_;
  bool link_ok_ = false;
  int64_t last_rx_us_ = 0;
  double battery_volts_;
  std::vector<double> temperatures_c_;
  std::thread thread_;
};

}  // namespace tsc

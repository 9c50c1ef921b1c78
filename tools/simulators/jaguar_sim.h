#pragma once
// The Jaguar board simulator behind `tsc jaguar-sim`: one board that speaks both protocols on
// 127.0.0.1 — the V2/V4 binary protocol on a UDP port and the 4x4/V6 ASCII protocol on a TCP
// port — and integrates what it is told into a planar pose (a skid-steer base: the two sides'
// speeds are power × full_power_mps). It streams encoders, battery and temperatures back as the
// real boards do, writes its true pose to a file for the simulated camera, and injects faults:
// dropped frames, corrupted frames (bad CRC / garbled lines), silence.
//
// Its own safety behaviour (documented, so tests do not mistake it for the driver's): the
// motors stop when the PC has been silent for silence_stop_s (any protocol) and when the TCP
// client disconnects. A real V2 board has no documented watchdog; the ASCII boards expect a
// PING every 200 ms.

#include <netinet/in.h>

#include <atomic>
#include <cstdint>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

namespace tsc {

struct JaguarSimOptions {
  int udp_port = 0;  ///< V2/V4 binary protocol; 0 = an ephemeral port
  int tcp_port = 0;  ///< 4x4/V6 ASCII protocol; 0 = an ephemeral port
  double start_x_m = 0.0, start_y_m = 0.0, start_heading_rad = 0.0;
  double full_power_mps = 1.5;  ///< side speed at full power
  double track_width_m = 0.52;
  double counts_per_metre = 640.0;  ///< encoder counts per metre of side travel
  double sensor_period_s = 0.1;     ///< sensor frames / report lines (~10 Hz, as the boards)
  double drop_fraction = 0.0;       ///< outgoing frames/lines dropped, in [0, 1]
  double bad_crc_fraction = 0.0;    ///< outgoing frames with a wrong CRC / garbled lines
  double silence_stop_s = 1.0;      ///< PC silent this long → motors stop; 0 = never
  double silence_at_s = -1.0;       ///< fault: from this time after start the board is silent
  double silence_for_s = 0.0;       ///< ... for this long
  std::string pose_file;            ///< "" or a file the pose is written to (atomically)
  double pose_period_s = 0.04;      ///< 25 Hz (the camera's contract: ≥ 20 Hz)
  uint32_t seed = 1;                ///< fault injection's random draws
  /// Throws std::invalid_argument naming the bad field.
  void Validate() const;
};

/// What the board is doing, for tests and the status line.
struct JaguarSimState {
  double x = 0.0, y = 0.0, heading = 0.0;
  double left = 0.0, right = 0.0;  ///< side powers in [−1, 1]
  bool moving = false;
  double flipper_front = 0.0, flipper_rear = 0.0;  ///< V2: ch0/ch1 power in [−1, 1]
  bool silent = false;                             ///< the silence fault is on
  bool estop = false;                              ///< ASCII: `!EX` latched until `!MG`
  int64_t stopped_at_us = 0;       ///< steady time the motors last went from moving to stopped
  std::string stopped_by;          ///< "command" | "pc silent" | "disconnect" | "estop"
  int64_t frames_in = 0;           ///< valid frames (UDP) received
  int64_t frames_rejected_in = 0;  ///< corrupted frames received
  int64_t acks_in = 0;
  int64_t lines_in = 0;  ///< TCP lines received
  int64_t pings_in = 0;
  int64_t sent = 0;       ///< frames/lines sent
  int64_t dropped = 0;    ///< frames/lines dropped by the fault injection
  int64_t corrupted = 0;  ///< frames/lines corrupted by the fault injection
  int64_t tcp_clients = 0;
};

class JaguarSim {
 public:
  /// Binds both ports on 127.0.0.1 and starts the board. Throws std::invalid_argument for bad
  /// options, std::runtime_error when a port cannot be bound.
  explicit JaguarSim(const JaguarSimOptions& options);
  ~JaguarSim();
  JaguarSim(const JaguarSim&) = delete;
  JaguarSim& operator=(const JaguarSim&) = delete;

  int udp_port() const { return udp_port_; }
  int tcp_port() const { return tcp_port_; }
  JaguarSimState state() const;
  /// Fault injection at run time.
  void SetSilent(bool silent);
  void SetDropFraction(double f);
  void SetBadCrcFraction(double f);

 private:
  void Run();
  void Integrate(int64_t now_us);
  void SetPowers(double left, double right, const char* why, int64_t now_us);
  void ReceiveUdp(int64_t now_us);
  void AcceptTcp(int64_t now_us);
  void ReceiveTcp(int64_t now_us);
  void HandleLine(const std::string& line, int64_t now_us);
  void SendSensors();
  void SendUdp(std::vector<uint8_t> frame);
  void SendLine(std::string line);
  void DropClient(int64_t now_us);
  void WritePose();
  bool Draw(double fraction);

  JaguarSimOptions options_;
  int udp_fd_ = -1, listen_fd_ = -1, client_fd_ = -1;
  int udp_port_ = 0, tcp_port_ = 0;
  bool have_peer_ = false;
  sockaddr_in peer_{};  // the PC's address, learned from its first frame
  std::string tcp_buffer_;
  std::atomic<bool> quit_{false};
  mutable std::mutex mutex_;
  JaguarSimState state_;
  double left_distance_m_ = 0.0, right_distance_m_ = 0.0;
  int64_t integrated_us_ = 0, last_heard_us_ = 0, start_us_ = 0;
  bool forced_silent_ = false;
  int64_t imu_seq_ = 0;
  std::mt19937 rng_;
  std::thread thread_;
};

}  // namespace tsc

#include "tools/simulators/jaguar_sim.h"

#include <arpa/inet.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <stdexcept>

#include "drivers/clock.h"
#include "drivers/motor/jaguar_ascii_protocol.h"
#include "drivers/motor/jaguar_v2_protocol.h"
#include "drivers/motor/link_socket.h"

namespace tsc {
namespace {

int64_t Now() { return Clock::System().SteadyMicros(); }

void CheckFraction(double f, const char* name) {
  if (!(f >= 0.0 && f <= 1.0)) {
    throw std::invalid_argument(std::string("jaguar-sim: ") + name + " " + std::to_string(f) +
                                " must be in [0, 1]");
  }
}

int BindLoopback(int type, int port) {
  const int fd = link::OpenSocket(type);
  const int one = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  const sockaddr_in a = link::Ipv4("127.0.0.1", port);  // never any other address
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&a), sizeof a) != 0 ||
      (type == SOCK_STREAM && ::listen(fd, 4) != 0)) {
    int copy = fd;
    link::CloseFd(copy);
    throw std::runtime_error("jaguar-sim: cannot bind 127.0.0.1:" + std::to_string(port) +
                             (type == SOCK_STREAM ? " (tcp)" : " (udp)"));
  }
  return fd;
}

double Clamp1(double v) { return std::clamp(v, -1.0, 1.0); }

}  // namespace

void JaguarSimOptions::Validate() const {
  if (udp_port < 0 || udp_port > 65535) throw std::invalid_argument("jaguar-sim: bad udp port");
  if (tcp_port < 0 || tcp_port > 65535) throw std::invalid_argument("jaguar-sim: bad tcp port");
  if (!std::isfinite(start_x_m) || !std::isfinite(start_y_m) || !std::isfinite(start_heading_rad))
    throw std::invalid_argument("jaguar-sim: start pose must be finite");
  if (!(full_power_mps > 0 && track_width_m > 0 && counts_per_metre > 0))
    throw std::invalid_argument("jaguar-sim: full power, track width and counts must be > 0");
  if (!(sensor_period_s >= 0.01 && sensor_period_s <= 1.0))
    throw std::invalid_argument("jaguar-sim: sensor period must be in [0.01, 1] s");
  if (!(pose_period_s > 0 && pose_period_s <= 0.05))
    throw std::invalid_argument("jaguar-sim: pose period must be in (0, 0.05] s (>= 20 Hz)");
  CheckFraction(drop_fraction, "drop fraction");
  CheckFraction(bad_crc_fraction, "bad CRC fraction");
  if (!(silence_stop_s >= 0)) throw std::invalid_argument("jaguar-sim: silence stop must be >= 0");
  if (!(silence_for_s >= 0)) throw std::invalid_argument("jaguar-sim: silence length must be >= 0");
}

JaguarSim::JaguarSim(const JaguarSimOptions& options)
    : options_((options.Validate(), options)), rng_(options.seed) {
  udp_fd_ = BindLoopback(SOCK_DGRAM, options_.udp_port);
  try {
    listen_fd_ = BindLoopback(SOCK_STREAM, options_.tcp_port);
  } catch (...) {
    link::CloseFd(udp_fd_);
    throw;
  }
  udp_port_ = link::LocalPort(udp_fd_);
  tcp_port_ = link::LocalPort(listen_fd_);
  state_.x = options_.start_x_m;
  state_.y = options_.start_y_m;
  state_.heading = std::remainder(options_.start_heading_rad, 2 * std::numbers::pi);
  start_us_ = integrated_us_ = last_heard_us_ = Now();
  WritePose();
  thread_ = std::thread([this] { Run(); });
}

JaguarSim::~JaguarSim() {
  quit_ = true;
  if (thread_.joinable()) thread_.join();
  link::CloseFd(client_fd_);
  link::CloseFd(listen_fd_);
  link::CloseFd(udp_fd_);
}

JaguarSimState JaguarSim::state() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return state_;
}

void JaguarSim::SetSilent(bool silent) {
  std::lock_guard<std::mutex> lock(mutex_);
  forced_silent_ = silent;
}
void JaguarSim::SetDropFraction(double f) {
  CheckFraction(f, "drop fraction");
  std::lock_guard<std::mutex> lock(mutex_);
  options_.drop_fraction = f;
}
void JaguarSim::SetBadCrcFraction(double f) {
  CheckFraction(f, "bad CRC fraction");
  std::lock_guard<std::mutex> lock(mutex_);
  options_.bad_crc_fraction = f;
}

bool JaguarSim::Draw(double fraction) {
  return fraction > 0.0 && std::uniform_real_distribution<double>(0.0, 1.0)(rng_) < fraction;
}

void JaguarSim::Integrate(int64_t now_us) {
  const double dt = static_cast<double>(now_us - integrated_us_) * 1e-6;
  integrated_us_ = now_us;
  if (dt <= 0.0 || !state_.moving) return;
  const double vl = state_.left * options_.full_power_mps;
  const double vr = state_.right * options_.full_power_mps;
  left_distance_m_ += vl * dt;
  right_distance_m_ += vr * dt;
  const double v = (vl + vr) / 2.0, w = (vr - vl) / options_.track_width_m;
  const double h = state_.heading;
  if (std::abs(w) < 1e-9) {
    state_.x += v * std::cos(h) * dt;
    state_.y += v * std::sin(h) * dt;
  } else {  // exact arc for constant side speeds
    const double h1 = h + w * dt;
    state_.x += v / w * (std::sin(h1) - std::sin(h));
    state_.y -= v / w * (std::cos(h1) - std::cos(h));
    state_.heading = std::remainder(h1, 2 * std::numbers::pi);
  }
}

void JaguarSim::SetPowers(double left, double right, const char* why, int64_t now_us) {
  Integrate(now_us);
  const bool was_moving = state_.moving;
  state_.left = Clamp1(left);
  state_.right = Clamp1(right);
  state_.moving = state_.left != 0.0 || state_.right != 0.0;
  if (was_moving && !state_.moving) {
    state_.stopped_at_us = now_us;
    state_.stopped_by = why;
  }
}

void JaguarSim::Run() {
  const auto period_us = static_cast<int64_t>(options_.sensor_period_s * 1e6);
  const auto pose_us = static_cast<int64_t>(options_.pose_period_s * 1e6);
  const auto silence_stop_us = static_cast<int64_t>(options_.silence_stop_s * 1e6);
  int64_t next_sensors = Now(), next_pose = Now();
  while (!quit_) {
    pollfd fds[3] = {{udp_fd_, POLLIN, 0}, {listen_fd_, POLLIN, 0}, {client_fd_, POLLIN, 0}};
    ::poll(fds, client_fd_ >= 0 ? 3 : 2, 5);
    const int64_t now = Now();
    std::lock_guard<std::mutex> lock(mutex_);
    const double t = static_cast<double>(now - start_us_) * 1e-6;
    state_.silent = forced_silent_ || (options_.silence_at_s >= 0 && t >= options_.silence_at_s &&
                                       t < options_.silence_at_s + options_.silence_for_s);
    if (fds[0].revents & POLLIN) ReceiveUdp(now);
    if (fds[1].revents & POLLIN) AcceptTcp(now);
    if (client_fd_ >= 0 && (fds[2].revents & (POLLIN | POLLHUP | POLLERR))) ReceiveTcp(now);
    if (state_.moving && silence_stop_us > 0 && now - last_heard_us_ > silence_stop_us) {
      SetPowers(0, 0, "pc silent", now);
    }
    Integrate(now);
    if (now >= next_sensors) {
      if (!state_.silent) SendSensors();
      next_sensors += period_us;
      if (next_sensors < now) next_sensors = now + period_us;
    }
    if (now >= next_pose && !options_.pose_file.empty()) {
      WritePose();
      next_pose += pose_us;  // on a fixed grid, so the rate holds despite the poll's jitter
      if (next_pose < now) next_pose = now + pose_us;
    }
  }
}

void JaguarSim::ReceiveUdp(int64_t now_us) {
  using namespace jaguar_v2;
  uint8_t buf[512];
  while (true) {
    sockaddr_in from{};
    socklen_t n_from = sizeof from;
    const ssize_t n = ::recvfrom(udp_fd_, buf, sizeof buf, MSG_DONTWAIT,
                                 reinterpret_cast<sockaddr*>(&from), &n_from);
    if (n < 0) return;
    if (state_.silent) continue;  // a hung board hears nothing either
    Reject reason{};
    const auto frame =
        Decode(std::span<const uint8_t>(buf, static_cast<size_t>(n)), &reason, kDestBoard);
    if (!frame) {
      ++state_.frames_rejected_in;
      continue;
    }
    ++state_.frames_in;
    peer_ = from;  // the board answers whoever talked to it last
    have_peer_ = true;
    last_heard_us_ = now_us;
    const auto type = static_cast<FrameType>(frame->type);
    if (type == FrameType::kSystem && !frame->data.empty()) {
      const auto cmd = static_cast<SystemCommand>(frame->data[0]);
      if (cmd == SystemCommand::kAck) ++state_.acks_in;
      if (cmd != SystemCommand::kPing) SendUdp(EncodeAck(kDestPc));
    } else if (type == FrameType::kPwmAll && frame->data.size() >= 12) {
      auto ch = [&](size_t i) {
        return static_cast<int16_t>(frame->data[2 * i] | (frame->data[2 * i + 1] << 8));
      };
      const int16_t c3 = ch(3), c4 = ch(4);
      // 0x8000 = no control: that channel keeps its value. The board mixes ch3 (forward
      // power) and ch4 (turn power, counter-clockwise positive) into the two sides.
      const double f = c3 == kNoControl ? (state_.left + state_.right) / 2
                                        : (c3 - kPwmStop) / double{kPwmMax - kPwmStop};
      const double w = c4 == kNoControl ? (state_.right - state_.left) / 2
                                        : (c4 - kPwmStop) / double{kPwmMax - kPwmStop};
      if (ch(0) != kNoControl)
        state_.flipper_front = (ch(0) - kPwmStop) / double{kPwmMax - kPwmStop};
      if (ch(1) != kNoControl)
        state_.flipper_rear = (ch(1) - kPwmStop) / double{kPwmMax - kPwmStop};
      SetPowers(f - w, f + w, "command", now_us);
    }
  }
}

void JaguarSim::AcceptTcp(int64_t now_us) {
  const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
  if (fd < 0) return;
  DropClient(now_us);  // one PC at a time: a new connection replaces the old one
  client_fd_ = fd;
  tcp_buffer_.clear();
  last_heard_us_ = now_us;
  ++state_.tcp_clients;
}

void JaguarSim::DropClient(int64_t now_us) {
  if (client_fd_ < 0) return;
  link::CloseFd(client_fd_);
  SetPowers(0, 0, "disconnect", now_us);
}

void JaguarSim::ReceiveTcp(int64_t now_us) {
  char buf[2048];
  while (client_fd_ >= 0) {
    const ssize_t n = ::recv(client_fd_, buf, sizeof buf, MSG_DONTWAIT);
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK)) {
      DropClient(now_us);
      return;
    }
    if (n < 0) return;
    if (state_.silent) continue;
    tcp_buffer_.append(buf, static_cast<size_t>(n));
    size_t nl;
    while ((nl = tcp_buffer_.find('\n')) != std::string::npos) {
      const std::string line = tcp_buffer_.substr(0, nl);
      tcp_buffer_.erase(0, nl + 1);
      HandleLine(line, now_us);
    }
    if (tcp_buffer_.size() > 4096) tcp_buffer_.clear();
  }
}

void JaguarSim::HandleLine(const std::string& line, int64_t now_us) {
  using namespace jaguar_ascii;
  ++state_.lines_in;
  last_heard_us_ = now_us;
  const CommandLine c = ParseCommand(line);
  switch (c.kind) {
    case CommandLine::Kind::kPing:
      ++state_.pings_in;
      return;
    case CommandLine::Kind::kEmergencyStop:
      state_.estop = true;
      SetPowers(0, 0, "estop", now_us);
      SendLine("MMW +\r\n");
      return;
    case CommandLine::Kind::kRelease:
      state_.estop = false;
      SendLine("MMW +\r\n");
      return;
    case CommandLine::Kind::kWheelPower:
      if (state_.estop) {
        SendLine("MMW -\r\n");  // e-stopped: rejected until released
        return;
      }
      // Mirrored sides: the right motor turns the other way for forward.
      SetPowers(c.left / double{kPowerMax}, -c.right / double{kPowerMax}, "command", now_us);
      SendLine("MMW +\r\n");
      return;
    case CommandLine::Kind::kFlipper:
    case CommandLine::Kind::kLights:
      SendLine("MM" + std::to_string(c.board) + " +\r\n");
      return;
    case CommandLine::Kind::kUnknown:
      SendLine("MMW -\r\n");
      return;
  }
}

void JaguarSim::SendUdp(std::vector<uint8_t> frame) {
  if (!have_peer_) return;
  if (Draw(options_.drop_fraction)) {
    ++state_.dropped;
    return;
  }
  if (Draw(options_.bad_crc_fraction)) {
    frame[frame.size() - 3] ^= 0x5A;  // the CRC byte
    ++state_.corrupted;
  }
  ::sendto(udp_fd_, frame.data(), frame.size(), MSG_DONTWAIT,
           reinterpret_cast<const sockaddr*>(&peer_), sizeof peer_);
  ++state_.sent;
}

void JaguarSim::SendLine(std::string line) {
  if (client_fd_ < 0 || state_.silent) return;
  if (Draw(options_.drop_fraction)) {
    ++state_.dropped;
    return;
  }
  if (Draw(options_.bad_crc_fraction) && line.size() > 4) {
    line.replace(line.size() / 2, 1, "?");  // garbled: a digit or a key lost
    ++state_.corrupted;
  }
  link::SendAll(client_fd_, line.data(), line.size());
  ++state_.sent;
}

void JaguarSim::SendSensors() {
  using namespace jaguar_v2;
  const auto l = static_cast<int64_t>(std::llround(left_distance_m_ * options_.counts_per_metre));
  const auto r = static_cast<int64_t>(std::llround(right_distance_m_ * options_.counts_per_metre));
  const double vl = state_.left * options_.full_power_mps;
  const double vr = state_.right * options_.full_power_mps;
  // V2/V4: the right track's encoder is mounted mirrored, so it counts down going forward.
  MotorSensor m;
  auto pwm = [](double p) { return static_cast<uint16_t>(std::lround(kPwmStop + p * 16383)); };
  m.output_pwm = {kPwmStop,
                  kPwmStop,
                  0x8000,
                  pwm((state_.left + state_.right) / 2),
                  pwm((state_.right - state_.left) / 2),
                  0x8000};
  CustomSensor c;
  c.analog[1] = static_cast<uint16_t>(std::lround(25.2 / 34.498 * 4095));  // 25.2 V battery
  for (size_t i = 2; i < 8; ++i) c.analog[i] = static_cast<uint16_t>(1900 + 10 * i);  // ~28 °C
  c.ch3_encoder = static_cast<uint16_t>(l & 0xFFFF);
  c.ch4_encoder = static_cast<uint16_t>((-r) & 0xFFFF);
  c.ch3_velocity = static_cast<uint16_t>(std::lround(std::abs(vl) * options_.counts_per_metre));
  c.ch4_velocity = static_cast<uint16_t>(std::lround(std::abs(vr) * options_.counts_per_metre));
  c.ch3_direction = vl < 0 ? 1 : 0;
  c.ch4_direction = vr < 0 ? 0 : 1;
  StandardSensor s{static_cast<uint16_t>(std::lround(5.0 / 9 * 4095)),
                   static_cast<uint16_t>(std::lround(25.2 / 34.498 * 4095))};
  SendUdp(
      Encode({kDestPc, 0, static_cast<uint8_t>(FrameType::kMotorSensor), SerializeMotorSensor(m)}));
  SendUdp(Encode(
      {kDestPc, 0, static_cast<uint8_t>(FrameType::kCustomSensor), SerializeCustomSensor(c)}));
  SendUdp(Encode(
      {kDestPc, 0, static_cast<uint8_t>(FrameType::kStandardSensor), SerializeStandardSensor(s)}));
  // 4x4/V6: the front wheel board reports counts (right mirrored), volts ×10, temperatures,
  // fault bits; the IMU its line.
  if (client_fd_ >= 0) {
    SendLine("MM0 C=" + std::to_string(l) + ":" + std::to_string(-r) + "\r\n");
    SendLine("MM0 V=120:252:50\r\n");
    SendLine("MM0 T=28:29\r\n");
    SendLine(std::string("MM0 FF=") + (state_.estop ? "16" : "0") + "\r\n");
    const double w = (vr - vl) / options_.track_width_m;
    char imu[200];
    std::snprintf(imu, sizeof imu, "#%lld,YAW,%.4f,GYRO,0,0,%.4f,ACC,0,0,9.81,COMP,0.2,0,0.4\r\n",
                  static_cast<long long>(++imu_seq_), state_.heading, w);
    SendLine(imu);
  }
}

void JaguarSim::WritePose() {
  if (options_.pose_file.empty()) return;
  const std::string tmp = options_.pose_file + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    char line[128];
    std::snprintf(line, sizeof line, "%.6f %.6f %.6f\n", state_.x, state_.y, state_.heading);
    out << line;
    if (!out) return;  // a full disk: the last good pose stays in place
  }
  std::error_code ec;
  std::filesystem::rename(tmp, options_.pose_file, ec);  // atomic: readers never see half
}

}  // namespace tsc

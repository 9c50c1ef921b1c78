#include "drivers/motor/jaguar_v2_base.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "drivers/motor/link_socket.h"

namespace tsc {
namespace {

using namespace jaguar_v2;

int16_t Pwm(double fraction) {
  const double p = kPwmStop + std::clamp(fraction, -1.0, 1.0) * (kPwmMax - kPwmStop);
  return static_cast<int16_t>(std::lround(std::clamp(p, 0.0, double{kPwmMax})));
}

constexpr int64_t kAckRetryUs = 500'000;  // while the link is down, ACK again this often

}  // namespace

JaguarV2Base::JaguarV2Base(const JaguarOptions& options, Clock& clock)
    : options_((options.Validate(), options)),
      clock_(clock),
      gate_(options_),
      odometry_(options_),
      battery_volts_(std::numeric_limits<double>::quiet_NaN()) {
  const sockaddr_in board = link::Ipv4(options_.host, options_.port);
  fd_ = link::OpenSocket(SOCK_DGRAM);
  // A connected UDP socket: only the board's datagrams arrive, send() needs no address.
  if (::connect(fd_, reinterpret_cast<const sockaddr*>(&board), sizeof board) != 0 ||
      ::pipe2(wake_, O_CLOEXEC | O_NONBLOCK) != 0) {
    const std::string why = std::strerror(errno);
    link::CloseFd(fd_);
    throw MotorError("jaguar-v2: cannot reach " + options_.host + ":" +
                     std::to_string(options_.port) + ": " + why);
  }
  thread_ = std::thread([this] { Run(); });
}

JaguarV2Base::~JaguarV2Base() {
  quit_ = true;
  const char c = 'q';
  (void)!::write(wake_[1], &c, 1);
  if (thread_.joinable()) thread_.join();
  // Never leave the motors running: three times, in case a datagram is lost.
  const auto stop = EncodePwmAll(AllStop());
  for (int i = 0; i < 3; ++i) SendBytes(stop);
  link::CloseFd(fd_);
  link::CloseFd(wake_[0]);
  link::CloseFd(wake_[1]);
}

void JaguarV2Base::Command(const MotorCommand& command) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    gate_.Command(command, clock_.SteadyMicros());
    if (!link_ok_) gate_.Halt("link lost");  // no driving blind
  }
  const char c = 'c';
  (void)!::write(wake_[1], &c, 1);
}

void JaguarV2Base::Stop() {
  std::lock_guard<std::mutex> lock(mutex_);
  gate_.Halt("stopped");
  SendDemand(gate_.At(clock_.SteadyMicros()));
}

Odometry JaguarV2Base::state() const {
  std::lock_guard<std::mutex> lock(mutex_);
  const DriveDemand d = gate_.At(clock_.SteadyMicros());
  Odometry o =
      SharedState(odometry_, sent_, link_ok_, battery_volts_, temperatures_c_, clock_.WallMicros());
  o.fault = link_ok_ ? d.reason : "link lost";
  if (o.fault == "stopped") o.fault.clear();
  o.left_ticks = left_.count() * options_.left_sign;
  o.right_ticks = right_.count() * options_.right_sign;
  return o;
}

JaguarLinkCounters JaguarV2Base::counters() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return counters_;
}

DecodeCounters JaguarV2Base::decode_counters() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return decode_;
}

void JaguarV2Base::SendBytes(const std::vector<uint8_t>& bytes) {
  // ECONNREFUSED (no board listening yet) is expected while the link is down.
  (void)::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
}

void JaguarV2Base::SendDemand(const DriveDemand& d) {
  PwmChannels pwm = AllStop();
  if (d.moving()) {
    const double full = options_.full_power_mps;
    pwm[0] = Pwm(d.flipper_front);
    pwm[1] = Pwm(d.flipper_rear);
    pwm[3] = Pwm(options_.forward_sign * d.linear_mps / full);
    pwm[4] = Pwm(options_.turn_sign * d.angular_radps * options_.track_width_m / 2.0 / full);
  }
  SendBytes(EncodePwmAll(pwm));
  ++counters_.commands_sent;
  if (!d.moving()) ++counters_.stops_sent;
  sent_ = d;
  next_send_us_ = clock_.SteadyMicros() + static_cast<int64_t>(options_.send_period_s * 1e6);
}

void JaguarV2Base::Run() {
  const int64_t timeout_us = static_cast<int64_t>(options_.link_timeout_s * 1e6);
  int64_t last_ack_us = INT64_MIN / 2;
  while (!quit_) {
    int64_t wait_us = 20'000;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      const int64_t now = clock_.SteadyMicros();
      // The link: lost after link_timeout_s of silence; while down, ACK so the board (back
      // from a reboot, or a new board) learns our address again.
      if (link_ok_ && now - last_rx_us_ > timeout_us) {
        link_ok_ = false;
        ++counters_.links_lost;
        gate_.Halt("link lost");
        odometry_.Restart();
        left_.Reset();
        right_.Reset();
      }
      if (!link_ok_ && now - last_ack_us >= kAckRetryUs) {
        SendBytes(EncodeAck());
        last_ack_us = now;
      }
      const DriveDemand d = gate_.At(now);
      if (!(d == sent_) || now >= next_send_us_) SendDemand(d);
      wait_us = std::min(wait_us, next_send_us_ - now);
      if (d.moving()) wait_us = std::min(wait_us, gate_.watchdog_deadline_us() - now);
    }
    pollfd fds[2] = {{fd_, POLLIN, 0}, {wake_[0], POLLIN, 0}};
    const int ms = static_cast<int>(std::clamp<int64_t>((wait_us + 999) / 1000, 0, 20));
    if (::poll(fds, 2, ms) < 0 && errno != EINTR) break;
    if (fds[1].revents & POLLIN) {
      char buf[64];
      while (::read(wake_[0], buf, sizeof buf) > 0) {
      }
    }
    if (fds[0].revents & (POLLIN | POLLERR)) Receive(clock_.SteadyMicros());
  }
}

void JaguarV2Base::Receive(int64_t now_us) {
  uint8_t buf[512];
  while (true) {
    const ssize_t n = ::recv(fd_, buf, sizeof buf, MSG_DONTWAIT);
    if (n < 0) return;  // EAGAIN, or ECONNREFUSED from an earlier send: nothing to read
    std::lock_guard<std::mutex> lock(mutex_);
    const auto frame = Decode(std::span<const uint8_t>(buf, static_cast<size_t>(n)), decode_);
    if (!frame) {
      ++counters_.frames_rejected;
      continue;
    }
    ++counters_.frames_received;
    last_rx_us_ = now_us;
    Handle(*frame, now_us);
  }
}

void JaguarV2Base::Handle(const Frame& frame, int64_t now_us) {
  switch (static_cast<FrameType>(frame.type)) {
    case FrameType::kMotorSensor:
      SendBytes(EncodeAck());  // the board expects an ACK for every motor sensor frame
      break;
    case FrameType::kCustomSensor:
      if (const auto s = ParseCustomSensor(frame.data)) {
        const int64_t l = left_.Update(s->ch3_encoder) * options_.left_sign;
        const int64_t r = right_.Update(s->ch4_encoder) * options_.right_sign;
        odometry_.Update(l, r, now_us);
        // The link is up with the first encoder report, so the odometry has its origin
        // before any command is taken (an ACK answer alone does not bring it up).
        if (!link_ok_) {
          link_ok_ = true;
          ++counters_.connects;
        }
        battery_volts_ = s->battery_volts();
        const auto t = s->temperatures_c();
        temperatures_c_.assign(t.begin(), t.end());
      } else {
        ++counters_.frames_rejected;
      }
      break;
    case FrameType::kStandardSensor:
      if (!ParseStandardSensor(frame.data)) ++counters_.frames_rejected;
      break;
    default:
      break;  // ACK answers and anything else: proof of life only
  }
}

}  // namespace tsc

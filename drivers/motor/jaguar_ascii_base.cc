#include "drivers/motor/jaguar_ascii_base.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <limits>

#include "drivers/motor/link_socket.h"

namespace tsc {
namespace {

using namespace jaguar_ascii;

constexpr int64_t kFirstBackoffUs = 200'000, kMaxBackoffUs = 2'000'000;

int Power(double fraction, int sign) {
  return sign * static_cast<int>(std::lround(std::clamp(fraction, -1.0, 1.0) * kPowerMax));
}

}  // namespace

JaguarAsciiBase::JaguarAsciiBase(const JaguarOptions& options, Clock& clock)
    : options_((options.Validate(), options)),
      clock_(clock),
      gate_(options_),
      odometry_(options_),
      battery_volts_(std::numeric_limits<double>::quiet_NaN()) {
  (void)link::Ipv4(options_.host, options_.port);  // a bad address fails here, not in the thread
  if (::pipe2(wake_, O_CLOEXEC | O_NONBLOCK) != 0) throw MotorError("jaguar-ascii: no pipe");
  thread_ = std::thread([this] { Run(); });
}

JaguarAsciiBase::~JaguarAsciiBase() {
  quit_ = true;
  const char c = 'q';
  (void)!::write(wake_[1], &c, 1);
  if (thread_.joinable()) thread_.join();
  if (fd_ >= 0) SendLine(jaguar_ascii::Stop());  // never leave the motors running
  link::CloseStream(fd_);
  link::CloseFd(wake_[0]);
  link::CloseFd(wake_[1]);
}

void JaguarAsciiBase::Command(const MotorCommand& command) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    gate_.Command(command, clock_.SteadyMicros());
    if (!link_ok_) gate_.Halt("link lost");
  }
  const char c = 'c';
  (void)!::write(wake_[1], &c, 1);
}

void JaguarAsciiBase::Stop() {
  std::lock_guard<std::mutex> lock(mutex_);
  gate_.Halt("stopped");
  if (fd_ >= 0) SendDemand(gate_.At(clock_.SteadyMicros()));
}

Odometry JaguarAsciiBase::state() const {
  std::lock_guard<std::mutex> lock(mutex_);
  const DriveDemand d = gate_.At(clock_.SteadyMicros());
  Odometry o =
      SharedState(odometry_, sent_, link_ok_, battery_volts_, temperatures_c_, clock_.WallMicros());
  // Our own reasons first (the board reports our `!EX` as its e-stop bit a moment later).
  o.fault = !link_ok_ ? "link lost" : d.estop || board_fault_.empty() ? d.reason : board_fault_;
  if (o.fault == "stopped") o.fault.clear();
  o.left_ticks = left_ticks_;
  o.right_ticks = right_ticks_;
  return o;
}

JaguarLinkCounters JaguarAsciiBase::counters() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return counters_;
}

std::optional<ImuLine> JaguarAsciiBase::imu() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return imu_;
}

bool JaguarAsciiBase::SendLine(const std::string& line) {
  return fd_ >= 0 && link::SendAll(fd_, line.data(), line.size());
}

void JaguarAsciiBase::SendDemand(const DriveDemand& d) {
  if (d.estop) {
    if (!sent_.estop) SendLine(EmergencyStop());
    released_ = false;
  } else if (d.moving()) {
    if (!released_) released_ = SendLine(Release());
    const SidePowers p =
        MixSides(d.linear_mps, d.angular_radps, options_.full_power_mps, options_.track_width_m);
    SendLine(WheelPower(Power(p.left, options_.left_sign), Power(p.right, options_.right_sign)));
  } else {
    SendLine(jaguar_ascii::Stop());
    ++counters_.stops_sent;
  }
  ++counters_.commands_sent;
  SendLine(Ping());  // the heartbeat rides along with every command (≤ send_period_s apart)
  sent_ = d;
  next_send_us_ = clock_.SteadyMicros() + static_cast<int64_t>(options_.send_period_s * 1e6);
}

bool JaguarAsciiBase::Connect() {
  int fd = -1;
  try {
    fd = link::OpenSocket(SOCK_STREAM);
  } catch (const MotorError&) {
    return false;
  }
  const sockaddr_in a = link::Ipv4(options_.host, options_.port);
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&a), sizeof a) != 0 && errno != EINPROGRESS) {
    link::CloseFd(fd);
    return false;
  }
  pollfd p{fd, POLLOUT, 0};
  int err = 0;
  socklen_t n = sizeof err;
  if (::poll(&p, 1, 500) != 1 || ::getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &n) != 0 ||
      err != 0) {
    link::CloseFd(fd);
    return false;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  fd_ = fd;
  lines_.Clear();
  // The boards may remember the last command: stop, then e-stop until we mean to drive.
  SendLine(jaguar_ascii::Stop());
  SendLine(EmergencyStop());
  released_ = false;
  link_ok_ = false;  // up with the first encoder line: the odometry needs its origin first
  last_rx_us_ = clock_.SteadyMicros();
  odometry_.Restart();  // the board's counters may have restarted with it
  sent_ = DriveDemand{};
  return true;
}

void JaguarAsciiBase::Disconnect(bool lost) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (lost) {
    if (link_ok_) ++counters_.links_lost;
    gate_.Halt("link lost");
  }
  link_ok_ = false;
  link::CloseFd(fd_);
}

void JaguarAsciiBase::Run() {
  const int64_t timeout_us = static_cast<int64_t>(options_.link_timeout_s * 1e6);
  int64_t backoff_us = kFirstBackoffUs, next_connect_us = 0;
  while (!quit_) {
    if (fd_ < 0) {
      const int64_t now = clock_.SteadyMicros();
      if (now >= next_connect_us) {
        if (Connect()) {
          backoff_us = kFirstBackoffUs;
        } else {
          next_connect_us = now + backoff_us;
          backoff_us = std::min(2 * backoff_us, kMaxBackoffUs);
        }
      }
    }
    int64_t wait_us = 20'000;
    bool lost = false;
    if (fd_ >= 0) {
      std::lock_guard<std::mutex> lock(mutex_);
      const int64_t now = clock_.SteadyMicros();
      if (now - last_rx_us_ > timeout_us) lost = true;
      const DriveDemand d = gate_.At(now);
      if (!lost && (!(d == sent_) || now >= next_send_us_)) SendDemand(d);
      wait_us = std::min(wait_us, next_send_us_ - now);
      if (d.moving()) wait_us = std::min(wait_us, gate_.watchdog_deadline_us() - now);
    }
    if (lost) {
      Disconnect(true);
      next_connect_us = clock_.SteadyMicros() + backoff_us;
      continue;
    }
    pollfd fds[2] = {{wake_[0], POLLIN, 0}, {fd_, POLLIN, 0}};
    const int ms = static_cast<int>(std::clamp<int64_t>((wait_us + 999) / 1000, 0, 20));
    if (::poll(fds, fd_ >= 0 ? 2 : 1, ms) < 0 && errno != EINTR) break;
    if (fds[0].revents & POLLIN) {
      char buf[64];
      while (::read(wake_[0], buf, sizeof buf) > 0) {
      }
    }
    if (fd_ >= 0 && (fds[1].revents & (POLLIN | POLLERR | POLLHUP))) {
      Receive(clock_.SteadyMicros());
    }
  }
}

void JaguarAsciiBase::Receive(int64_t now_us) {
  char buf[4096];
  while (true) {
    const ssize_t n = ::recv(fd_, buf, sizeof buf, MSG_DONTWAIT);
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) {
      Disconnect(true);  // the board closed the connection, or it broke
      return;
    }
    if (n < 0) return;
    std::lock_guard<std::mutex> lock(mutex_);
    lines_.Feed(std::string_view(buf, static_cast<size_t>(n)));
    while (auto line = lines_.Next()) Handle(*line, now_us);
  }
}

void JaguarAsciiBase::Handle(const std::string& line, int64_t now_us) {
  const ReplyLine r = ParseReply(line);
  if (r.kind == ReplyLine::Kind::kMalformed) {
    ++counters_.frames_rejected;
    return;
  }
  ++counters_.frames_received;
  last_rx_us_ = now_us;
  if (r.kind == ReplyLine::Kind::kImu) {
    imu_ = r.imu;
    return;
  }
  if (r.kind == ReplyLine::Kind::kAcknowledge) {
    if (!r.ack.accepted) ++counters_.frames_rejected;
    return;
  }
  if (r.kind != ReplyLine::Kind::kMotorBoard) return;
  const MotorBoardLine& m = r.motor;
  if (m.board == 0 && m.key == "C" && m.values.size() >= 2) {
    left_ticks_ = m.values[0] * options_.left_sign;
    right_ticks_ = m.values[1] * options_.right_sign;
    odometry_.Update(left_ticks_, right_ticks_, now_us);
    if (!link_ok_) {
      link_ok_ = true;
      ++counters_.connects;
    }
  } else if (m.board == 0 && m.key == "V" && m.values.size() >= 2) {
    battery_volts_ = static_cast<double>(m.values[1]) / 10.0;  // V=internal:battery:5V, ×10
  } else if (m.key == "T" && m.board >= 0 && m.board < 4) {
    temperatures_c_.resize(8, std::numeric_limits<double>::quiet_NaN());
    for (size_t i = 0; i < std::min<size_t>(2, m.values.size()); ++i) {
      temperatures_c_[static_cast<size_t>(m.board) * 2 + i] = static_cast<double>(m.values[i]);
    }
  } else if (m.key == "FF" && !m.values.empty() && m.board < 2) {
    board_fault_ = FaultText(m.values[0]);
  }
}

}  // namespace tsc

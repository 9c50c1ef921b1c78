#include "daemon/motor_bridge.h"

#include <spdlog/spdlog.h>

#include <boost/asio/io_context.hpp>
#include <boost/asio/steady_timer.hpp>
#include <chrono>

#include "daemon/log_throttle.h"
#include "jaguar/motor_command_t.hpp"
#include "jaguar/motor_state_t.hpp"

namespace tsc {

struct MotorBridge::Timer {
  explicit Timer(boost::asio::io_context& io) : timer(io) {}
  boost::asio::steady_timer timer;
};

MotorBridge::MotorBridge(MotorBase& base, uint32_t robot, TeamBus& bus, boost::asio::io_context& io,
                         DaemonCounters& counters)
    : base_(base),
      robot_(robot),
      bus_(bus),
      counters_(counters),
      timer_(std::make_unique<Timer>(io)) {}

MotorBridge::~MotorBridge() = default;

void MotorBridge::Subscribe() {
  bus_.lcm().Subscribe(
      "JAGUAR_CMD_" + std::to_string(robot_),
      [this](const std::string& c, const uint8_t* d, size_t n) { OnCommand(c, d, n); });
}

void MotorBridge::Start() { OnTimer(); }

void MotorBridge::StopMotors() {
  stopped_ = true;
  base_.Stop();
}

void MotorBridge::Cancel() {
  // A wait that completed before the cancel still runs its handler with success: the flag
  // keeps it from arming the timer again (that kept a stopping tscd's loop alive).
  cancelled_ = true;
  timer_->timer.cancel();
}

void MotorBridge::OnTimer() {
  const Odometry odo = base_.state();
  jaguar::motor_state_t m{};
  m.utime = NowUtime();
  m.x = odo.x;
  m.y = odo.y;
  m.heading = odo.heading;
  m.linear_mps = odo.linear_mps;
  m.angular_radps = odo.angular_radps;
  m.left_ticks = odo.left_ticks;  // 0 on a simulated base: no encoders
  m.right_ticks = odo.right_ticks;
  m.battery_volts = odo.battery_volts;
  m.temperatures_c = odo.temperatures_c;
  m.num_temperatures = static_cast<int16_t>(m.temperatures_c.size());
  m.link_ok = odo.link_ok;
  m.stopped = odo.stopped;
  m.fault = odo.fault;
  const std::string channel = "JAGUAR_STATE_" + std::to_string(robot_);
  if (!bus_.lcm().Publish(channel, m)) bus_.PublishFailed(channel);
  timer_->timer.expires_after(std::chrono::milliseconds(100));
  timer_->timer.async_wait([this](const boost::system::error_code& ec) {
    if (!ec && !cancelled_) OnTimer();
  });
}

void MotorBridge::OnCommand(const std::string& channel, const uint8_t* data, size_t size) {
  if (stopped_) return;  // shutting down: the motors stay stopped
  const auto c = LcmBus::Decode<jaguar::motor_command_t>(data, size);
  if (!c) {
    const int64_t n = ++counters_.messages_rejected;
    if (ShouldLog(n)) {
      spdlog::warn("{}: dropped a malformed motor command ({} bytes)", channel, size);
    }
    return;
  }
  base_.Command(MotorCommand{c->linear_mps, c->angular_radps, c->estop != 0, c->flipper_front,
                             c->flipper_rear});
}

}  // namespace tsc

// The Jaguar drivers against the board simulator over real sockets on 127.0.0.1 (ephemeral
// ports), for both protocols: commands move the simulated pose and the odometry follows; the
// command watchdog, e-stop, speed limits, link silence and reconnection, corrupted frames, and
// the destructor's stop.

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <memory>
#include <thread>

#include "drivers/clock.h"
#include "drivers/motor/jaguar_ascii_base.h"
#include "drivers/motor/jaguar_v2_base.h"
#include "tools/simulators/jaguar_sim.h"

namespace tsc {
namespace {

using std::chrono::milliseconds;

int64_t Now() { return Clock::System().SteadyMicros(); }

/// Polls `done` every 10 ms for up to `timeout`.
bool WaitFor(const std::function<bool()>& done, milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (done()) return true;
    std::this_thread::sleep_for(milliseconds(10));
  }
  return done();
}

class JaguarDriverTest : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    sim_ = std::make_unique<JaguarSim>(sim_options_);
    dut_ = MakeDriver();
    ASSERT_TRUE(WaitFor([&] { return dut_->state().link_ok; }, milliseconds(3000)))
        << "no link to the simulator";
  }
  std::unique_ptr<MotorBase> MakeDriver(Clock& clock = Clock::System()) {
    JaguarOptions o;
    o.host = "127.0.0.1";
    o.port = ascii() ? sim_->tcp_port() : sim_->udp_port();
    if (ascii()) return std::make_unique<JaguarAsciiBase>(o, clock);
    return std::make_unique<JaguarV2Base>(o, clock);
  }
  /// A new simulator with `options` and a new driver on `clock`, linked.
  void Restart(const JaguarSimOptions& options, Clock& clock) {
    dut_.reset();
    sim_ = std::make_unique<JaguarSim>(options);
    dut_ = MakeDriver(clock);
    ASSERT_TRUE(WaitFor([&] { return dut_->state().link_ok; }, milliseconds(3000)))
        << "no link to the simulator";
  }
  bool ascii() const { return GetParam() == "ascii"; }
  JaguarLinkCounters link_counters() const {
    if (ascii()) return static_cast<JaguarAsciiBase&>(*dut_).counters();
    return static_cast<JaguarV2Base&>(*dut_).counters();
  }
  /// Commands (v, ω) every 100 ms, as a teleop would, until the simulated board's state
  /// satisfies `done` (true) or 10 s pass (false). The verdict rests on what the board did,
  /// not on how long the machine took to do it: a loaded machine only makes it slower.
  bool DriveUntil(double v, double w, const std::function<bool(const JaguarSimState&)>& done) {
    const auto deadline = std::chrono::steady_clock::now() + milliseconds(10000);
    while (std::chrono::steady_clock::now() < deadline) {
      dut_->Command({v, w});
      if (done(sim_->state())) return true;
      std::this_thread::sleep_for(milliseconds(100));
    }
    return done(sim_->state());
  }
  static bool Moving(const JaguarSimState& s) { return s.moving; }
  /// Waits (generously) until the driver's odometry, less `origin`, agrees with the board's
  /// pose less `true_origin` within `xy` metres and `heading` radians: the last encoder
  /// reports take a while to arrive on a loaded machine. The caller's EXPECTs give the verdict.
  void AwaitOdometry(double xy, double heading, const JaguarSimState& true_origin = {},
                     const Odometry& origin = {}) {
    WaitFor(
        [&] {
          const JaguarSimState t = sim_->state();
          const Odometry o = dut_->state();
          return std::abs((o.x - origin.x) - (t.x - true_origin.x)) < xy &&
                 std::abs((o.y - origin.y) - (t.y - true_origin.y)) < xy &&
                 std::abs((o.heading - origin.heading) - (t.heading - true_origin.heading)) <
                     heading;
        },
        milliseconds(5000));
  }
  bool SimStopsWithin(milliseconds timeout) {
    return WaitFor([&] { return !sim_->state().moving; }, timeout);
  }

  /// The simulator's own silence rule is off: only the driver stops the motors, so the generous
  /// timeouts above cannot let the board's rule pass for the driver's stop on a slow machine.
  JaguarSimOptions sim_options_ = [] {
    JaguarSimOptions o;
    o.silence_stop_s = 0.0;
    return o;
  }();
  std::unique_ptr<JaguarSim> sim_;
  std::unique_ptr<MotorBase> dut_;
};

TEST_P(JaguarDriverTest, VelocityCommandsMoveThePoseAndOdometryFollows) {
  ASSERT_TRUE(DriveUntil(0.5, 0.4, [](const JaguarSimState& s) {
    return std::hypot(s.x, s.y) > 0.4 && s.heading > 0.3;
  })) << "the simulated base did not move forward and turn left";
  dut_->Stop();
  ASSERT_TRUE(SimStopsWithin(milliseconds(3000)));
  AwaitOdometry(0.02, 0.03);
  const JaguarSimState truth = sim_->state();
  const Odometry odo = dut_->state();
  EXPECT_NEAR(odo.x, truth.x, 0.02);
  EXPECT_NEAR(odo.y, truth.y, 0.02);
  EXPECT_NEAR(odo.heading, truth.heading, 0.03);
  EXPECT_GT(odo.left_ticks, 0);
  EXPECT_GT(odo.right_ticks, odo.left_ticks);  // the right side drove further: a left turn
  EXPECT_TRUE(odo.stopped);
  EXPECT_EQ(odo.fault, "");
  EXPECT_NEAR(odo.battery_volts, 25.2, 0.05);
  ASSERT_GE(odo.temperatures_c.size(), 2u);
  EXPECT_NEAR(odo.temperatures_c[0], 28.0, 3.0);
  if (ascii()) {
    const auto imu = static_cast<JaguarAsciiBase&>(*dut_).imu();
    ASSERT_TRUE(imu);
    EXPECT_NEAR(imu->yaw, truth.heading, 0.1);
  }
}

TEST_P(JaguarDriverTest, BackwardAndClockwiseHaveTheirSigns) {
  ASSERT_TRUE(DriveUntil(-0.4, -0.5, [](const JaguarSimState& s) {
    return s.heading < -0.2 && s.x < -0.2;
  })) << "the simulated base did not move backward and turn clockwise";
  dut_->Stop();
  ASSERT_TRUE(SimStopsWithin(milliseconds(3000)));
  AwaitOdometry(0.02, 0.03);
  const JaguarSimState truth = sim_->state();
  EXPECT_LT(truth.heading, -0.2);
  EXPECT_LT(truth.x, -0.2);
  EXPECT_NEAR(dut_->state().x, truth.x, 0.02);
  EXPECT_NEAR(dut_->state().heading, truth.heading, 0.03);
}

// The 0.5 s command watchdog on an injected clock: the driver's time moves only when the test
// says, so the verdict does not depend on how busy the machine is. The simulator's own
// silence rule is off, so only the driver can stop the motors. Real time only bounds the waits
// for the link and the simulator to see what the driver sent (generous timeouts).
TEST_P(JaguarDriverTest, WatchdogStopsTheMotorsHalfASecondAfterTheLastCommand) {
  JaguarSimOptions options;
  options.silence_stop_s = 0.0;
  ManualClock clock;
  Restart(options, clock);
  dut_->Command({0.5, 0.0});
  ASSERT_TRUE(WaitFor([&] { return sim_->state().moving; }, milliseconds(3000)));
  // An ASCII board reports the e-stop the driver set at connection until its next report
  // after the release (10 Hz): wait for it to clear.
  ASSERT_TRUE(WaitFor([&] { return dut_->state().fault.empty(); }, milliseconds(3000)))
      << dut_->state().fault;
  // 1 ms before the deadline: still driving, however long the machine takes.
  clock.Advance(499'000);
  EXPECT_EQ(dut_->state().fault, "");
  EXPECT_FALSE(dut_->state().stopped);
  std::this_thread::sleep_for(milliseconds(200));  // the link thread runs meanwhile
  EXPECT_TRUE(sim_->state().moving) << "stopped before the watchdog deadline";
  EXPECT_EQ(dut_->state().fault, "");
  // At the deadline: the driver stops the motors and says why.
  clock.Advance(1'000);
  EXPECT_EQ(dut_->state().fault, "watchdog");
  ASSERT_TRUE(SimStopsWithin(milliseconds(3000)));
  EXPECT_EQ(sim_->state().stopped_by, "command");  // the driver stopped it
  EXPECT_TRUE(dut_->state().stopped);
  // A new command feeds the watchdog again.
  dut_->Command({0.5, 0.0});
  ASSERT_TRUE(WaitFor([&] { return sim_->state().moving; }, milliseconds(3000)));
  EXPECT_EQ(dut_->state().fault, "");
}

// The same on the real clock, as a figure: the delay is recorded and printed, not asserted
// (scheduling on a loaded machine adds to it); only "never before 0.5 s" must hold.
TEST_P(JaguarDriverTest, WatchdogOnTheRealClockNeverStopsEarly) {
  JaguarSimOptions options;
  options.silence_stop_s = 0.0;
  Restart(options, Clock::System());
  const int64_t last_command_us = Now();  // before Command() stamps it: a lower bound
  dut_->Command({0.5, 0.0});
  ASSERT_TRUE(WaitFor([&] { return sim_->state().moving; }, milliseconds(3000)));
  ASSERT_TRUE(SimStopsWithin(milliseconds(10000)));
  const JaguarSimState s = sim_->state();
  EXPECT_EQ(s.stopped_by, "command");
  const double after_s = static_cast<double>(s.stopped_at_us - last_command_us) * 1e-6;
  RecordProperty("stop_after_ms", static_cast<int>(after_s * 1000));
  std::printf("watchdog stop %.3f s after the last command (0.5 s + scheduling)\n", after_s);
  EXPECT_GE(after_s, 0.5);
  EXPECT_EQ(dut_->state().fault, "watchdog");
}

TEST_P(JaguarDriverTest, SpeedLimitsClampCommands) {
  // Limit 1 m/s of 1.5 m/s full power: side power 2/3.
  ASSERT_TRUE(DriveUntil(10.0, 0.0, Moving));
  const JaguarSimState s = sim_->state();
  EXPECT_NEAR(s.left, 1.0 / 1.5, 0.01);
  EXPECT_NEAR(s.right, 1.0 / 1.5, 0.01);
  // 1.5 rad/s · 0.26 m = 0.39 m/s per side.
  ASSERT_TRUE(DriveUntil(0.0, 50.0, [](const JaguarSimState& t) { return t.left < 0; }));
  EXPECT_NEAR(sim_->state().right, 1.5 * 0.26 / 1.5, 0.01);
  dut_->Command({std::nan(""), 0.0});  // non-finite counts as zero
  EXPECT_TRUE(SimStopsWithin(milliseconds(3000)));
}

TEST_P(JaguarDriverTest, EstopStopsAndLatchesUntilAClearCommand) {
  ASSERT_TRUE(DriveUntil(0.5, 0.0, Moving));
  MotorCommand estop;
  estop.estop = true;
  dut_->Command(estop);
  ASSERT_TRUE(SimStopsWithin(milliseconds(3000)));
  EXPECT_EQ(dut_->state().fault, "estop");
  if (ascii()) {
    EXPECT_EQ(sim_->state().stopped_by, "estop");  // `!EX` reached the board
  }
  dut_->Stop();  // Stop() does not clear a latched e-stop
  EXPECT_EQ(dut_->state().fault, "estop");
  // A command without estop releases it. An ASCII board reports its e-stop until its next
  // report after the release (10 Hz): drive until that arrives.
  EXPECT_TRUE(DriveUntil(
      0.5, 0.0, [&](const JaguarSimState& t) { return t.moving && dut_->state().fault.empty(); }));
  EXPECT_EQ(dut_->state().fault, "");
}

TEST_P(JaguarDriverTest, SilentBoardIsALostLinkAndReconnectionNeedsANewCommand) {
  ASSERT_TRUE(DriveUntil(0.3, 0.0, Moving));
  sim_->SetSilent(true);
  // Keep commanding, as a teleop would: the driver must still declare the link lost (2 s).
  ASSERT_TRUE(WaitFor(
      [&] {
        dut_->Command({0.3, 0.0});
        return !dut_->state().link_ok;
      },
      milliseconds(3500)));
  EXPECT_EQ(dut_->state().fault, "link lost");
  EXPECT_EQ(link_counters().links_lost, 1);
  dut_->Command({0.3, 0.0});  // refused while the link is down
  EXPECT_TRUE(dut_->state().stopped);
  sim_->SetSilent(false);
  ASSERT_TRUE(WaitFor([&] { return dut_->state().link_ok; }, milliseconds(3000)));
  EXPECT_EQ(link_counters().connects, 2);
  // Back, but not driving blind on an old command: stopped until the next one.
  std::this_thread::sleep_for(milliseconds(300));
  EXPECT_FALSE(sim_->state().moving);
  // Motion the board made while it was silent is not in the odometry (the counters may have
  // restarted with the board): odometry resumes from where it was and follows from there.
  const JaguarSimState true0 = sim_->state();
  const Odometry odo0 = dut_->state();
  const double true_x0 = true0.x, odo_x0 = odo0.x;
  ASSERT_TRUE(DriveUntil(0.3, 0.0, [&](const JaguarSimState& s) { return s.x - true_x0 > 0.1; }));
  dut_->Stop();
  ASSERT_TRUE(SimStopsWithin(milliseconds(3000)));
  AwaitOdometry(0.02, 0.03, true0, odo0);
  EXPECT_GT(sim_->state().x - true_x0, 0.1);
  EXPECT_NEAR(dut_->state().x - odo_x0, sim_->state().x - true_x0, 0.02);
}

TEST_P(JaguarDriverTest, CorruptedAndDroppedFramesAreCountedAndSurvived) {
  sim_->SetBadCrcFraction(0.2);
  sim_->SetDropFraction(0.2);
  // Drive until both kinds of fault were met and the base went some way.
  ASSERT_TRUE(DriveUntil(0.4, 0.0, [&](const JaguarSimState& s) {
    return s.x > 0.3 && s.corrupted > 0 && link_counters().frames_rejected > 0;
  }));
  dut_->Stop();
  ASSERT_TRUE(SimStopsWithin(milliseconds(3000)));
  EXPECT_TRUE(dut_->state().link_ok);
  EXPECT_GT(link_counters().frames_rejected, 0);
  EXPECT_GT(sim_->state().corrupted, 0);
  if (!ascii()) {
    const auto d = static_cast<JaguarV2Base&>(*dut_).decode_counters();
    EXPECT_GT(d.rejected[static_cast<size_t>(jaguar_v2::Reject::kBadCrc)], 0);
  }
  sim_->SetBadCrcFraction(0.0);
  sim_->SetDropFraction(0.0);
  AwaitOdometry(0.02, 0.03);
  // Encoders are positions, so lost reports cost nothing once a good one arrives.
  EXPECT_NEAR(dut_->state().x, sim_->state().x, 0.02);
}

TEST_P(JaguarDriverTest, DestroyingTheDriverStopsTheMotors) {
  ASSERT_TRUE(DriveUntil(0.5, 0.0, Moving));
  const int64_t before = Now();
  dut_.reset();
  ASSERT_TRUE(SimStopsWithin(milliseconds(3000)));
  const JaguarSimState s = sim_->state();
  EXPECT_EQ(s.stopped_by, "command");  // the driver's stop (the board's own rule is off)
  // How fast is a figure of the machine's load, printed, not asserted.
  std::printf("stopped %.3f s after the driver was destroyed\n",
              static_cast<double>(s.stopped_at_us - before) * 1e-6);
}

INSTANTIATE_TEST_SUITE_P(Protocols, JaguarDriverTest, ::testing::Values("v2", "ascii"),
                         [](const auto& param_info) { return param_info.param; });

// Flipper speed commands are V2/V4 only (the ASCII boards move flippers by position).
TEST(JaguarV2Base, FlippersOnChannelsZeroAndOne) {
  JaguarSim sim({});
  JaguarOptions o;
  o.host = "127.0.0.1";
  o.port = sim.udp_port();
  JaguarV2Base dut(o);
  ASSERT_TRUE(WaitFor([&] { return dut.state().link_ok; }, milliseconds(3000)));
  MotorCommand c;
  c.flipper_front = 0.5;
  c.flipper_rear = -2.0;  // clamped to −1
  dut.Command(c);
  ASSERT_TRUE(WaitFor([&] { return sim.state().flipper_front > 0.4; }, milliseconds(3000)));
  EXPECT_NEAR(sim.state().flipper_front, 0.5, 0.001);
  EXPECT_NEAR(sim.state().flipper_rear, -1.0, 0.001);
  EXPECT_FALSE(sim.state().moving);  // the tracks were not told to move
  // The watchdog stops the flippers too (its timing is WatchdogStopsTheMotors...'s; here a
  // generous wait, as only the driver stops flippers).
  EXPECT_TRUE(WaitFor([&] { return sim.state().flipper_front == 0.0; }, milliseconds(3000)));
  EXPECT_EQ(sim.state().flipper_rear, 0.0);
}

TEST(JaguarSim, StopsOnItsOwnWhenThePcFallsSilent) {
  JaguarSimOptions o;
  o.silence_stop_s = 0.3;
  JaguarSim sim(o);
  JaguarOptions d;
  d.host = "127.0.0.1";
  d.port = sim.udp_port();
  // A driver that commands and is then frozen (as by kill -9) is modelled by closing its
  // socket without a stop: here, a raw socket sends one PWM frame and goes quiet.
  {
    JaguarV2Base dut(d);
    ASSERT_TRUE(WaitFor([&] { return dut.state().link_ok; }, milliseconds(3000)));
  }
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(sim.udp_port()));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  jaguar_v2::PwmChannels pwm = jaguar_v2::AllStop();
  pwm[3] = 24000;
  const auto frame = jaguar_v2::EncodePwmAll(pwm);
  ::sendto(fd, frame.data(), frame.size(), 0, reinterpret_cast<sockaddr*>(&a), sizeof a);
  ASSERT_TRUE(WaitFor([&] { return sim.state().moving; }, milliseconds(3000)));
  ASSERT_TRUE(WaitFor([&] { return !sim.state().moving; }, milliseconds(5000)));
  EXPECT_EQ(sim.state().stopped_by, "pc silent");
  ::close(fd);
}

}  // namespace
}  // namespace tsc

#include "drivers/base/sim_base.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <thread>

#include "drivers/clock.h"

namespace tsc {
namespace {

constexpr int64_t kMs = 1000;

class SimBaseTest : public ::testing::Test {
 protected:
  /// Sends `command` every 100 ms for `seconds` (keeps the watchdog fed).
  void Drive(const MotorCommand& command, double seconds) {
    const int steps = static_cast<int>(std::lround(seconds * 10.0));
    for (int i = 0; i < steps; ++i) {
      dut_.Command(command);
      clock_.Advance(100 * kMs);
    }
  }
  ManualClock clock_;
  SimBase dut_{SimBaseOptions{}, clock_};
};

TEST_F(SimBaseTest, IntegratesStraightLine) {
  Drive({0.5, 0.0, false}, 1.0);
  const Odometry odometry = dut_.state();
  EXPECT_NEAR(odometry.x, 0.5, 1e-9);
  EXPECT_NEAR(odometry.y, 0.0, 1e-9);
  EXPECT_NEAR(odometry.heading, 0.0, 1e-9);
  EXPECT_DOUBLE_EQ(odometry.linear_mps, 0.5);
  EXPECT_FALSE(odometry.stopped);
  EXPECT_EQ(odometry.fault, "");
}

TEST_F(SimBaseTest, IntegratesArcExactly) {
  // Half a circle of radius 1 m: v = 0.5 m/s, ω = 0.5 rad/s for 2π s.
  const MotorCommand arc{0.5, 0.5, false};
  for (int i = 0; i < 31; ++i) {
    dut_.Command(arc);
    clock_.Advance(std::llround(2.0 * std::numbers::pi * 1e6 / 31.0));
  }
  const Odometry odometry = dut_.state();
  EXPECT_NEAR(odometry.x, 0.0, 1e-3);
  EXPECT_NEAR(odometry.y, 2.0, 1e-3);
  EXPECT_NEAR(std::abs(odometry.heading), std::numbers::pi, 1e-3);
}

TEST_F(SimBaseTest, WatchdogStopsAfterHalfSecondWithoutCommands) {
  dut_.Command({0.5, 0.0, false});
  clock_.Advance(300 * kMs);
  EXPECT_FALSE(dut_.state().stopped);
  clock_.Advance(700 * kMs);
  const Odometry odometry = dut_.state();
  EXPECT_TRUE(odometry.stopped);
  EXPECT_EQ(odometry.fault, "watchdog");
  EXPECT_DOUBLE_EQ(odometry.linear_mps, 0.0);
  EXPECT_NEAR(odometry.x, 0.25, 1e-9);  // moved only until the deadline
  // A new command moves again and clears the fault.
  dut_.Command({0.5, 0.0, false});
  clock_.Advance(100 * kMs);
  EXPECT_EQ(dut_.state().fault, "");
  EXPECT_NEAR(dut_.state().x, 0.30, 1e-9);
}

TEST_F(SimBaseTest, EstopLatchesUntilCommandWithoutEstop) {
  Drive({0.5, 0.0, false}, 0.2);
  dut_.Command({0.5, 0.0, true});
  clock_.Advance(200 * kMs);
  Odometry odometry = dut_.state();
  EXPECT_TRUE(odometry.stopped);
  EXPECT_EQ(odometry.fault, "estop");
  const double x = odometry.x;
  EXPECT_NEAR(x, 0.1, 1e-9);
  dut_.Stop();  // an explicit stop does not clear the latch
  clock_.Advance(600 * kMs);
  EXPECT_EQ(dut_.state().fault, "estop");  // nor does the watchdog
  dut_.Command({0.5, 0.0, false});
  clock_.Advance(200 * kMs);
  odometry = dut_.state();
  EXPECT_EQ(odometry.fault, "");
  EXPECT_NEAR(odometry.x, x + 0.1, 1e-9);
}

TEST_F(SimBaseTest, ClampsCommandsToLimits) {
  SimBaseOptions options;
  options.max_linear_mps = 0.3;
  options.max_angular_radps = 0.5;
  SimBase dut(options, clock_);
  dut.Command({2.0, -3.0, false});
  Odometry odometry = dut.state();
  EXPECT_DOUBLE_EQ(odometry.linear_mps, 0.3);
  EXPECT_DOUBLE_EQ(odometry.angular_radps, -0.5);
  dut.Command({-2.0, std::nan(""), false});
  odometry = dut.state();
  EXPECT_DOUBLE_EQ(odometry.linear_mps, -0.3);
  EXPECT_DOUBLE_EQ(odometry.angular_radps, 0.0);
}

TEST_F(SimBaseTest, StartsAtStartPoseAndStopHalts) {
  SimBaseOptions options;
  options.start_x_m = 3.0;
  options.start_y_m = -1.0;
  options.start_heading_rad = std::numbers::pi / 2;
  SimBase dut(options, clock_);
  EXPECT_TRUE(dut.state().stopped);
  dut.Command({1.0, 0.0, false});
  clock_.Advance(200 * kMs);
  dut.Stop();
  clock_.Advance(200 * kMs);
  const Odometry odometry = dut.state();
  EXPECT_NEAR(odometry.x, 3.0, 1e-9);
  EXPECT_NEAR(odometry.y, -0.8, 1e-9);
  EXPECT_TRUE(odometry.stopped);
  EXPECT_EQ(odometry.fault, "");
}

TEST_F(SimBaseTest, BadOptionsAreRejectedNamingTheField) {
  SimBaseOptions options;
  options.watchdog_s = 0.0;
  try {
    SimBase dut(options, clock_);
    FAIL() << "a zero watchdog must be rejected";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("watchdog_s"), std::string::npos) << e.what();
  }
}

TEST_F(SimBaseTest, CommandsAndReadsFromTwoThreads) {
  SimBase dut(SimBaseOptions{}, Clock::System());
  std::atomic<bool> done{false};
  std::thread reader([&] {
    while (!done) {
      const Odometry odometry = dut.state();
      ASSERT_TRUE(std::isfinite(odometry.x));
    }
  });
  for (int i = 0; i < 2000; ++i) dut.Command({0.2, 0.1, false});
  done = true;
  reader.join();
  EXPECT_FALSE(dut.state().stopped);
}

}  // namespace
}  // namespace tsc

// A complete simulated Jaguar of real processes: `tsc jaguar-sim` (the V2 motor board, on
// 127.0.0.1, writing its true pose to a pose file), `tsc axis-sim` (the Axis PTZ camera,
// rendering the same simulated world at that pose, Digest authentication), tscd with the
// configuration a real Jaguar uses except for the addresses (camera.source = axis,
// motor.driver = jaguar-v2, from a config file) and `tsc teleop` fed a scripted key sequence.
// Real udpm:// LCM inside the test's private network namespace. Checks: the teleop keys drive
// the board through the world, the camera rides on the board's pose (tscd learns >= 2 places
// and maps >= 1 edge, as the pure simulation does), tscd exits 0 on SIGTERM and the board
// reports its motors stopped by command afterwards.

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <optional>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "jaguar/motor_state_t.hpp"
#include "store/store.h"
#include "test/daemon/bus_listener.h"
#include "test/support/child_process.h"
#include "test/support/sim_pose.h"
#include "test/support/temp_dir.h"

namespace tsc {
namespace {

namespace fs = std::filesystem;
using std::chrono::milliseconds;
using std::chrono::seconds;
using testing_support::BusListener;
using testing_support::ChildProcess;
using testing_support::Distance;
using testing_support::MotorStateSink;
using testing_support::Quote;
using testing_support::ReadSimPose;
using testing_support::SimPose;

const std::string kBin = TSCD_BIN_DIR;

/// Waits until `pattern`'s first group appears in the process's output; "" if it never does.
std::string WaitForMatch(ChildProcess& p, const std::regex& pattern, seconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    std::smatch m;
    const std::string log = p.Log();
    if (std::regex_search(log, m, pattern)) return m[1].str();
    if (!p.running()) break;
    std::this_thread::sleep_for(milliseconds(20));
  }
  return "";
}

// Keys every 50 ms: `n` times `key` (as a held key repeats), then silence.
std::string Keys(char key, int n) {
  return "i=0; while [ $i -lt " + std::to_string(n) + " ]; do printf " + std::string(1, key) +
         "; sleep 0.05; i=$((i+1)); done";
}

// The robot's processes, started step by step; each step ASSERTs what the next relies on.
class SimulatedRobot : public ::testing::Test {
 protected:
  SimulatedRobot()
      : temp_("simulated_robot_test"), dir_(temp_.path()), pose_file_(dir_ / "pose.txt") {}

  // The board: V2 protocol on a free UDP port; it starts at the first pose of robot 0's route
  // in world 1 (inside the world) and writes its true pose at 25 Hz.
  void StartBoard() {
    board_.emplace(std::vector<std::string>{kBin + "/tsc", "jaguar-sim", "--world", "1",
                                            "--udp-port", "0", "--pose-file", pose_file_.string()},
                   dir_ / "jaguar-sim.log");
    motor_port_ = WaitForMatch(*board_, std::regex("udp 127\\.0\\.0\\.1:(\\d+)"), seconds(10));
    ASSERT_FALSE(motor_port_.empty()) << board_->Log();
    for (int i = 0; i < 250 && !ReadSimPose(pose_file_); ++i) {
      std::this_thread::sleep_for(milliseconds(20));
    }
    start_ = ReadSimPose(pose_file_);
    ASSERT_TRUE(start_) << "no pose in " << pose_file_ << "\n" << board_->Log();
  }

  // The camera: the same world, at the board's pose.
  void StartCamera() {
    password_ = dir_ / "axis.password";
    std::ofstream(password_) << "s3cret\n";
    ::chmod(password_.c_str(), 0600);
    camera_.emplace(
        std::vector<std::string>{kBin + "/tsc", "axis-sim", "--port", "0", "--world", "1",
                                 "--pose-file", pose_file_.string(), "--auth", "digest", "--user",
                                 "root", "--password-file", password_.string()},
        dir_ / "axis-sim.log");
    camera_port_ =
        WaitForMatch(*camera_, std::regex("serving http://127\\.0\\.0\\.1:([0-9]+)"), seconds(10));
    ASSERT_FALSE(camera_port_.empty()) << camera_->Log();
  }

  // tscd configured as on a Jaguar, addresses aside. Deviations, all for the test's time and
  // the shared CPU: 160x120 frames, no PTZ sweep (sweep_steps = 1: one view per base point),
  // announces every 0.2 s. detection.tau_p = 3: the drive at 10 frames/s gives ~225 base
  // points, and the default tau_p = 25 (for a camera sampled every ~0.15 m on long runs) prunes
  // all but one place of a route this short (tried: 1 learned, 0 mapped; with 3: 4-5 learned,
  // 3-4 mapped); places of more than 3 base points are kept. camera.spacing_m = 0.15 keeps
  // every frame a base point: the board's odometry would measure the drive's 0.05 m a frame and
  // take one in three (BasePointPicker; TscdTest.ASlowerRobotsOdometrySetsTheStride), ~80 base
  // points, too few on this route for two places (tried: 1 learned, 0 mapped). Returns once the
  // motor link is up and the camera delivers frames (the first frames are of the start).
  void StartTscd() {
    const fs::path config = dir_ / "tscd.ini";
    {
      std::ofstream out(config);
      out << "[robot]\nid = 1\n"
          << "[daemon]\nstate_dir = " << (dir_ / "state").string() << "\n"
          << "[detection]\ntau_p = 3\n"
          << "[camera]\nsource = axis\nfps = 10\nwidth = 160\nheight = 120\n"
          << "axis_host = 127.0.0.1\naxis_port = " << camera_port_ << "\naxis_user = root\n"
          << "axis_password_file = " << password_.string() << "\nsweep_steps = 1\n"
          << "spacing_m = 0.15\n"
          << "[lcm]\nannounce_period_s = 0.2\n"
          << "[motor]\ndriver = jaguar-v2\naddress = 127.0.0.1\nport = " << motor_port_ << "\n";
    }
    bus_.emplace();
    state_.emplace("JAGUAR_STATE_1");
    tscd_.emplace(std::vector<std::string>{kBin + "/tscd", "--config", config.string()},
                  dir_ / "tscd.log");
    const auto link_deadline = std::chrono::steady_clock::now() + seconds(20);
    while (std::chrono::steady_clock::now() < link_deadline &&
           !(state_->last() && state_->last()->link_ok)) {
      std::this_thread::sleep_for(milliseconds(50));
    }
    ASSERT_TRUE(state_->last() && state_->last()->link_ok) << tscd_->Log() << board_->Log();
    ASSERT_TRUE(bus_->WaitFor(
        [](const BusListener& b) {
          return b.announces.count("TSC_ANNOUNCE") &&
                 b.announces.at("TSC_ANNOUNCE").back().frames > 0;
        },
        seconds(20)))
        << tscd_->Log() << camera_->Log();
  }

  // The route, about 20 s of held keys: forward, left, forward, right, forward, round to the
  // left, forward, then silence (teleop's dead man stops the board 0.4 s after the last key).
  // Follows the board's true pose while it drives: the path length and how far it got from
  // the start; `end_` is where it stopped.
  void Drive() {
    const std::string keys = Keys('w', 60) + "; " + Keys('a', 40) + "; " + Keys('w', 60) + "; " +
                             Keys('d', 30) + "; " + Keys('w', 60) + "; " + Keys('a', 60) + "; " +
                             Keys('w', 80) + "; sleep 1";
    ChildProcess teleop(
        {"/bin/sh", "-c",
         "(" + keys + ") | " + Quote(kBin + "/tsc") + " teleop --robot 1 --hold-s 0.4"},
        dir_ / "teleop.log");
    SimPose last = *start_;
    const auto drive_deadline = std::chrono::steady_clock::now() + seconds(45);
    while (teleop.running() && std::chrono::steady_clock::now() < drive_deadline) {
      std::this_thread::sleep_for(milliseconds(100));
      if (const auto p = ReadSimPose(pose_file_)) {
        path_m_ += Distance(last, *p);
        farthest_m_ = std::max(farthest_m_, Distance(*start_, *p));
        last = *p;
      }
    }
    EXPECT_EQ(teleop.Wait(seconds(5)), 0) << teleop.Log();
    std::this_thread::sleep_for(milliseconds(500));
    end_ = ReadSimPose(pose_file_);
    ASSERT_TRUE(end_);
    std::printf("route: %.2f m driven, %.2f m at the farthest, %.2f m from the start at the end\n",
                path_m_, farthest_m_, Distance(*start_, *end_));
    RecordProperty("path_m", std::to_string(path_m_));
  }

  // Stopped by teleop's dead man, and tscd's odometry agrees with the board's true motion.
  // Without the simulated camera's sim.* keys the odometry starts at (0, 0, 0): it is the
  // board's displacement in the frame of its start pose.
  void CheckOdometry() {
    const auto odometry = state_->last();
    ASSERT_TRUE(odometry);
    EXPECT_TRUE(odometry->stopped);
    const double dx = end_->x - start_->x, dy = end_->y - start_->y;
    const double c = std::cos(start_->heading), s = std::sin(start_->heading);
    EXPECT_NEAR(odometry->x, c * dx + s * dy, 0.05);
    EXPECT_NEAR(odometry->y, -s * dx + c * dy, 0.05);
    EXPECT_NEAR(std::remainder(odometry->heading - (end_->heading - start_->heading), 2 * M_PI),
                0.0, 0.05);
  }

  // tscd stops on SIGTERM (the motors, the open place closed); what it learned and mapped, on
  // the bus and in its store. Returns the base points it announced last.
  int64_t StopTscdAndCheckWhatItLearned() {
    tscd_->Signal(SIGTERM);
    EXPECT_EQ(tscd_->Wait(seconds(20)), 0) << tscd_->Log();
    std::this_thread::sleep_for(milliseconds(200));
    int learned = 0, mapped = 0;
    int64_t frames = 0;
    bus_->Inspect([&](const BusListener& b) {
      if (b.announces.count("TSC_ANNOUNCE")) frames = b.announces.at("TSC_ANNOUNCE").back().frames;
      if (!b.events.count("TSC_EVENT_1")) return;
      for (const place_event_t& e : b.events.at("TSC_EVENT_1")) {
        learned += e.event == "learned" ? 1 : 0;
        mapped += e.event == "mapped" && e.has_from ? 1 : 0;
      }
    });
    std::printf("%d places learned, %d edges mapped from %lld base points\n", learned, mapped,
                static_cast<long long>(frames));
    RecordProperty("learned", learned);
    RecordProperty("mapped", mapped);
    EXPECT_GE(learned, 2) << tscd_->Log();
    EXPECT_GE(mapped, 1) << tscd_->Log();
    EXPECT_GT(frames, 100) << "the camera did not keep up: " << tscd_->Log();
    EXPECT_NE(tscd_->Log().find("axis:127.0.0.1:" + camera_port_), std::string::npos)
        << tscd_->Log();
    EXPECT_EQ(tscd_->Log().find("camera errors so far"), std::string::npos) << tscd_->Log();
    // The store holds what the bus reported.
    Store store = Store::Open(dir_ / "state" / "memory.db");
    EXPECT_GE(store.Load(1, PipelineOptions{}.memory).memory.places().size(), 2u);
    return frames;
  }

  // The board: stopped, and by a command (tscd's stop on SIGTERM or the dead man's), not by
  // its own silence rule; the camera served at least every frame tscd took.
  void StopBoardAndCamera(int64_t frames) {
    EXPECT_TRUE(std::abs(ReadSimPose(pose_file_).value_or(SimPose{}).x - end_->x) < 1e-6)
        << "the board moved after the route";
    board_->Signal(SIGTERM);
    EXPECT_EQ(board_->Wait(seconds(10)), 0) << board_->Log();
    EXPECT_NE(board_->Log().find("stopped by command"), std::string::npos) << board_->Log();
    camera_->Signal(SIGTERM);
    EXPECT_EQ(camera_->Wait(seconds(10)), 0) << camera_->Log();
    std::smatch served;
    const std::string camera_log = camera_->Log();
    ASSERT_TRUE(std::regex_search(camera_log, served, std::regex("stopped after ([0-9]+) frames")))
        << camera_log;
    EXPECT_GE(std::stoll(served[1]), frames) << camera_log;
  }

  testing_support::TempDir temp_;
  const fs::path dir_;
  const fs::path pose_file_;
  fs::path password_;
  std::string motor_port_, camera_port_;
  std::optional<SimPose> start_, end_;
  double path_m_ = 0, farthest_m_ = 0;
  // On the bus only once the test knows it runs in a private network namespace.
  std::optional<BusListener> bus_;
  std::optional<MotorStateSink> state_;
  // Destroyed in reverse: tscd before the camera and the board it talks to.
  std::optional<ChildProcess> board_, camera_, tscd_;
};

TEST_F(SimulatedRobot, TeleopDrivesARouteAndTscdLearnsPlacesFromTheAxisCamera) {
  TSCD_REQUIRE_PRIVATE_NETNS();
  const auto test_start = std::chrono::steady_clock::now();
  ASSERT_NO_FATAL_FAILURE(StartBoard());
  ASSERT_NO_FATAL_FAILURE(StartCamera());
  ASSERT_NO_FATAL_FAILURE(StartTscd());
  ASSERT_NO_FATAL_FAILURE(Drive());
  // 280 forward keys at 0.5 m/s make at least 7 m; the board went well away from its start.
  EXPECT_GT(path_m_, 5.0) << board_->Log();
  EXPECT_GT(farthest_m_, 2.0) << board_->Log();
  ASSERT_NO_FATAL_FAILURE(CheckOdometry());
  const int64_t frames = StopTscdAndCheckWhatItLearned();
  StopBoardAndCamera(frames);
  const auto took = std::chrono::steady_clock::now() - test_start;
  RecordProperty("seconds", static_cast<int>(std::chrono::duration_cast<seconds>(took).count()));
}

}  // namespace
}  // namespace tsc

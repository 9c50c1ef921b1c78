// A simulated robot's camera half as real processes: `tsc axis-sim` serves the simulated world
// over VAPIX (Digest authentication) at a pose the test moves along a scripted route through
// the pose file (as `tsc jaguar-sim --pose-file` does), and tscd with camera.source = axis
// learns places from it, inside the test's private network namespace.

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <thread>

#include "drivers/world/scenario.h"
#include "store/store.h"
#include "test/daemon/bus_listener.h"
#include "test/support/child_process.h"
#include "test/support/temp_dir.h"

namespace tsc {
namespace {

namespace fs = std::filesystem;
using std::chrono::milliseconds;
using std::chrono::seconds;
using testing_support::BusListener;
using testing_support::ChildProcess;

const std::string kBin = TSCD_BIN_DIR;

// Waits for axis-sim to print its port.
int WaitForPort(ChildProcess& sim) {
  const std::regex serving("serving http://127\\.0\\.0\\.1:([0-9]+)");
  for (int i = 0; i < 500; ++i) {
    std::smatch m;
    const std::string log = sim.Log();
    if (std::regex_search(log, m, serving)) return std::stoi(m[1]);
    if (!sim.running()) break;
    std::this_thread::sleep_for(milliseconds(20));
  }
  return 0;
}

// Writes `x y heading` atomically (rename), as the Jaguar simulator does.
void WritePose(const fs::path& file, const sim::Pose2& p) {
  const fs::path tmp = file.string() + ".tmp";
  {
    std::ofstream out(tmp);
    out << p.x << " " << p.y << " " << p.heading << "\n";
  }
  fs::rename(tmp, file);
}

// Runs axis-sim and tscd (camera.source = axis plus `extra` settings) while the robot moves
// along its route, one route pose every `tick`, until tscd has learned 3 places and 2 map
// edges. Returns tscd's last announce and the frames axis-sim served.
struct RobotRun {
  announce_t announce{};
  int64_t frames_served = 0;
  std::string tscd_log;
  std::string sim_log;
};

// `sim_extra`: more arguments of axis-sim; `camera_errors`: whether tscd may log camera errors.
RobotRun RunRobot(const std::vector<std::string>& extra, milliseconds tick,
                  const std::vector<std::string>& sim_extra = {}, bool camera_errors = false) {
  RobotRun out;
  testing_support::TempDir temp("axis_tscd_test");
  const fs::path dir = temp.path();
  const fs::path password = dir / "axis.password";
  std::ofstream(password) << "s3cret\n";
  ::chmod(password.c_str(), 0600);

  // The route of robot 0 in world 1, as the pure simulation drives it.
  sim::SimOptions world;
  world.seed = 1;
  const sim::Scenario scenario = sim::MakeScenario(world);
  const std::vector<sim::RouteFrame>& route = scenario.routes.at(0);
  const fs::path pose_file = dir / "pose";
  WritePose(pose_file, route.front().pose);

  std::vector<std::string> sim_argv = {
      kBin + "/tsc",     "axis-sim",         "--port", "0",      "--world", "1",
      "--pose-file",     pose_file.string(), "--auth", "digest", "--user",  "root",
      "--password-file", password.string()};
  sim_argv.insert(sim_argv.end(), sim_extra.begin(), sim_extra.end());
  ChildProcess sim(sim_argv, dir / "axis-sim.log");
  const int port = WaitForPort(sim);
  EXPECT_GT(port, 0) << sim.Log();
  if (port == 0) return out;

  BusListener bus;
  // The route is short and, with a sweep, a base point takes several frames: places span few
  // base points, so tscd runs with a small plenitude threshold (tau_p 3, as for keyframes).
  std::vector<std::string> argv = {kBin + "/tscd",
                                   "--robot",
                                   "1",
                                   "--state-dir",
                                   (dir / "state").string(),
                                   "--set",
                                   "camera.source=axis",
                                   "--set",
                                   "camera.axis_host=127.0.0.1",
                                   "--set",
                                   "camera.axis_port=" + std::to_string(port),
                                   "--set",
                                   "camera.axis_user=root",
                                   "--set",
                                   "camera.axis_password_file=" + password.string(),
                                   "--set",
                                   "camera.width=160",
                                   "--set",
                                   "camera.height=120",
                                   "--set",
                                   "lcm.announce_period_s=0.2",
                                   "--set",
                                   "detection.tau_p=3"};
  for (const std::string& e : extra) {
    argv.push_back("--set");
    argv.push_back(e);
  }
  ChildProcess tscd(argv, dir / "tscd.log");

  std::atomic<bool> stop{false};
  std::atomic<size_t> index{0};
  std::thread mover([&] {
    for (size_t i = 0; i < route.size() && !stop; ++i) {
      WritePose(pose_file, route[i].pose);
      index = i;
      std::this_thread::sleep_for(tick);
    }
  });
  const bool learned = bus.WaitFor(
      [](const BusListener& b) {
        if (!b.announces.count("TSC_ANNOUNCE")) return false;
        const announce_t& a = b.announces.at("TSC_ANNOUNCE").back();
        return a.places >= 3 && a.edges >= 2;
      },
      seconds(90));
  stop = true;
  mover.join();
  EXPECT_TRUE(learned) << "route pose " << index << " of " << route.size() << "\n"
                       << tscd.Log() << sim.Log();
  std::printf("3 places and 2 map edges learned by route pose %zu of %zu\n", index.load(),
              route.size());
  bus.Inspect([&](const BusListener& b) {
    if (b.announces.count("TSC_ANNOUNCE")) out.announce = b.announces.at("TSC_ANNOUNCE").back();
  });
  EXPECT_EQ(out.announce.status.find("degraded"), std::string::npos) << out.announce.status;

  tscd.Signal(SIGTERM);
  EXPECT_EQ(tscd.Wait(seconds(20)), 0) << tscd.Log();
  EXPECT_NE(tscd.Log().find("axis:127.0.0.1:" + std::to_string(port)), std::string::npos)
      << tscd.Log();
  if (!camera_errors) {
    EXPECT_EQ(tscd.Log().find("camera errors so far"), std::string::npos) << tscd.Log();
  }
  out.tscd_log = tscd.Log();
  Store store = Store::Open(dir / "state" / "memory.db");
  EXPECT_GE(store.Load(1, PipelineOptions{}.memory).memory.places().size(), 3u);

  sim.Signal(SIGTERM);
  EXPECT_EQ(sim.Wait(seconds(10)), 0) << sim.Log();
  const std::regex stopped("stopped after ([0-9]+) frames");
  std::smatch m;
  const std::string log = sim.Log();
  EXPECT_TRUE(std::regex_search(log, m, stopped)) << log;
  if (!m.empty()) out.frames_served = std::stoll(m[1]);
  out.sim_log = log;
  return out;
}

TEST(AxisTscd, APasswordFileOthersCanReadIsAConfigurationError) {
  testing_support::TempDir temp("axis_tscd_test");
  const fs::path password = temp.path() / "axis.password";
  std::ofstream(password) << "s3cret\n";
  ::chmod(password.c_str(), 0644);
  ChildProcess tscd(
      {kBin + "/tscd", "--state-dir", (temp.path() / "state").string(), "--set",
       "camera.source=axis", "--set", "camera.axis_host=127.0.0.1", "--set",
       "camera.axis_user=root", "--set", "camera.axis_password_file=" + password.string()},
      temp.path() / "tscd.log");
  EXPECT_EQ(tscd.Wait(seconds(20)), 78) << tscd.Log();
  EXPECT_NE(tscd.Log().find("camera.axis_password_file"), std::string::npos) << tscd.Log();
  EXPECT_NE(tscd.Log().find("0644"), std::string::npos) << tscd.Log();
}

TEST(AxisTscd, LearnsPlacesFromTheSimulatedAxisCamera) {
  TSCD_REQUIRE_PRIVATE_NETNS();
  // One view per base point at 20 fps; the robot moves one route pose every 50 ms.
  const RobotRun run = RunRobot({"camera.fps=20"}, milliseconds(50));
  EXPECT_GT(run.announce.frames, 20);
}

// Issue 18: every 10th frame of the MJPEG stream is a JPEG whose header claims 20512x35225
// pixels (2.2 GB decoded). tscd refuses each one it reads from its header (the camera, frame
// number and claim in the log, counted as camera errors), stays on the stream and learns from
// the frames between them as before. (tscd decodes only the newest of the parts it reads at
// once, so it may pass over a bomb unread; over the whole run it reads some.)
TEST(AxisTscd, BombFramesInTheStreamAreRefusedAndLearningGoesOn) {
  TSCD_REQUIRE_PRIVATE_NETNS();
  const RobotRun run = RunRobot({"camera.fps=20"}, milliseconds(50), {"--bomb-every", "10"}, true);
  EXPECT_GT(run.announce.frames, 20);
  EXPECT_NE(run.sim_log.find(" bombs"), std::string::npos) << run.sim_log;
  EXPECT_NE(run.tscd_log.find("refused: its header claims 20512x35225 pixels"), std::string::npos)
      << run.tscd_log;
  EXPECT_NE(run.tscd_log.find("camera errors so far"), std::string::npos) << run.tscd_log;
  size_t refused = 0;
  for (size_t at = 0;
       (at = run.tscd_log.find("refused: its header claims", at)) != std::string::npos; ++at) {
    ++refused;
  }
  std::printf("%zu bombs refused by tscd (%s)\n", refused,
              run.sim_log.substr(run.sim_log.rfind("stopped after")).c_str());
}

TEST(AxisTscd, LearnsPlacesWithAPtzSweepAtEveryBasePoint) {
  TSCD_REQUIRE_PRIVATE_NETNS();
  // A 360° sweep of 6 views per base point: tscd accumulates them into one bubble surface.
  const RobotRun run = RunRobot(
      {"camera.fps=30", "camera.sweep_steps=6", "camera.sweep_settle_s=0.02"}, milliseconds(150));
  ASSERT_GT(run.announce.frames, 5);
  // Every base point took 6 views, each after at least one dropped frame.
  EXPECT_GE(run.frames_served, 12 * run.announce.frames);
  std::printf("%lld base points from %lld frames served\n",
              static_cast<long long>(run.announce.frames),
              static_cast<long long>(run.frames_served));
}

}  // namespace
}  // namespace tsc

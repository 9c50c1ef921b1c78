#include "drivers/camera/sim_camera.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "drivers/base/sim_base.h"
#include "drivers/clock.h"
#include "drivers/world/dataset_writer.h"
#include "test/support/temp_dir.h"

namespace tsc {
namespace {
namespace fs = std::filesystem;

SimCameraOptions Small(std::uint32_t seed = 7) {
  SimCameraOptions options;
  options.scene.seed = seed;
  options.scene.render.width = 80;
  options.scene.render.height = 60;
  options.fps = 0.0;
  return options;
}

std::vector<cv::Mat> FirstFrames(SimCamera& camera, int n) {
  std::vector<cv::Mat> out;
  for (int i = 0; i < n; ++i) out.push_back(camera.Next().value().observation.bgr);
  return out;
}

double Difference(const cv::Mat& a, const cv::Mat& b) { return cv::norm(a, b, cv::NORM_L1); }

class SimCameraTest : public ::testing::Test {
 protected:
  ManualClock clock_;
};

TEST_F(SimCameraTest, SameSeedGivesIdenticalFramesAndOtherSeedDiffers) {
  SimCamera a(Small(7), clock_), b(Small(7), clock_), c(Small(8), clock_);
  const auto fa = FirstFrames(a, 3), fb = FirstFrames(b, 3), fc = FirstFrames(c, 3);
  for (size_t i = 0; i < fa.size(); ++i) {
    EXPECT_EQ(fa[i].type(), CV_8UC3);
    EXPECT_EQ(fa[i].size(), cv::Size(80, 60));
    EXPECT_EQ(Difference(fa[i], fb[i]), 0.0) << "frame " << i;
  }
  EXPECT_GT(Difference(fa[0], fc[0]), 0.0);
  EXPECT_EQ(a.intrinsics().width(), 80);
  EXPECT_EQ(a.name(), "sim:office/7/route 0");
}

TEST_F(SimCameraTest, OneRobotFramesAreTheFramesTscSimWrites) {
  testing_support::TempDir temp("tscd_sim_camera_test");
  SimCameraOptions options = Small(11);
  options.scene.png = true;
  options.scene.max_frames = 3;
  sim::WriteSimulatedDataset(temp.path() / "out", options.scene);
  SimCamera dut(options, clock_);
  for (int i = 1; i <= 3; ++i) {
    const cv::Mat written =
        cv::imread((temp.path() / "out" / ("00000" + std::to_string(i) + ".png")).string());
    ASSERT_FALSE(written.empty());
    EXPECT_EQ(Difference(dut.Next().value().observation.bgr, written), 0.0) << "frame " << i;
  }
  EXPECT_FALSE(dut.Next().has_value());
}

TEST_F(SimCameraTest, PanSweepDeliversTheViewsOfEachPoseAndTscSimWritesThemSideBySide) {
  testing_support::TempDir temp("tscd_sim_camera_test");
  SimCameraOptions options = Small(11);
  options.scene.png = true;
  options.scene.max_frames = 2;
  options.scene.sweep = PanSweep(3, 360.0);
  sim::WriteSimulatedDataset(temp.path() / "out", options.scene);
  SimCamera dut(options, clock_);
  EXPECT_EQ(dut.intrinsics().width(), 80);  // one view's
  for (int i = 1; i <= 2; ++i) {
    const cv::Mat written =
        cv::imread((temp.path() / "out" / ("00000" + std::to_string(i) + ".png")).string());
    ASSERT_EQ(written.size(), cv::Size(3 * 80, 60));
    for (int j = 0; j < 3; ++j) {
      const std::optional<CameraFrame> view = dut.Next();
      ASSERT_TRUE(view.has_value());
      EXPECT_EQ(view->ends_base_point, j == 2) << "frame " << i << " view " << j;
      EXPECT_NEAR(view->observation.pan_tilt.pan_rad, j * 2.0 * std::numbers::pi / 3.0, 1e-12);
      EXPECT_EQ(Difference(view->observation.bgr, written(cv::Rect(80 * j, 0, 80, 60))), 0.0)
          << "frame " << i << " view " << j;
    }
  }
  EXPECT_FALSE(dut.Next().has_value());
}

TEST_F(SimCameraTest, EndsAtRouteEndUnlessLooping) {
  SimCameraOptions options = Small();
  options.scene.max_frames = 4;
  SimCamera dut(options, clock_);
  int n = 0;
  while (dut.Next()) ++n;
  EXPECT_EQ(n, 4);

  options.loop = true;
  SimCamera looping(options, clock_);
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(looping.Next().has_value());
  const auto fifth = looping.Next();
  ASSERT_TRUE(fifth.has_value());
  EXPECT_EQ(fifth->sequence, 4);
  EXPECT_NEAR(looping.last().pose.x, looping.route().front().pose.x, 0.2);  // back at the start
}

TEST_F(SimCameraTest, LoopingRouteIsClosedSoThatALapEndsWhereTheNextBegins) {
  SimCameraOptions options = Small();
  options.scene.render.width = 16;
  options.scene.render.height = 12;
  const SimCamera once(options, clock_);
  options.loop = true;
  const SimCamera looping(options, clock_);
  ASSERT_GT(looping.route().size(), once.route().size());
  const sim::Pose2& end = looping.route().back().pose;
  const sim::Pose2& start = looping.route().front().pose;
  EXPECT_LE(std::hypot(end.x - start.x, end.y - start.y), options.scene.route.step_m + 1e-9);
  const sim::Pose2& open_end = once.route().back().pose;
  EXPECT_GT(std::hypot(open_end.x - start.x, open_end.y - start.y), 1.0);
}

// A robot started again where it stood (tsc soak's restarts of a looping robot): the route
// goes on from sim.start_frame, modulo its length.
TEST_F(SimCameraTest, StartFrameStartsTheRouteThereModuloItsLength) {
  SimCameraOptions options = Small();
  options.scene.max_frames = 6;
  options.scene.jitter_heading_deg = 0;  // the poses delivered are the route's
  options.scene.jitter_position_m = 0;
  options.loop = true;
  options.start_frame = 6 + 4;  // a lap and four frames
  SimCamera resumed(options, clock_);
  const auto same = [](const sim::Pose2& a, const sim::Pose2& b) {
    return a.x == b.x && a.y == b.y && a.heading == b.heading;
  };
  ASSERT_TRUE(resumed.Next().has_value());
  EXPECT_TRUE(same(resumed.last().pose, resumed.route()[4].pose));
  EXPECT_FALSE(same(resumed.last().pose, resumed.route()[0].pose));
  ASSERT_TRUE(resumed.Next().has_value());
  EXPECT_TRUE(same(resumed.last().pose, resumed.route()[5].pose));
  ASSERT_TRUE(resumed.Next().has_value());  // past the cut: the next lap
  EXPECT_TRUE(same(resumed.last().pose, resumed.route()[0].pose));
  options.start_frame = -1;
  EXPECT_THROW(SimCamera(options, clock_), std::invalid_argument);
}

TEST_F(SimCameraTest, WholeRouteEndsAfterItsLastFrame) {
  SimCameraOptions options = Small();
  options.scene.render.width = 16;
  options.scene.render.height = 12;
  SimCamera dut(options, clock_);
  size_t n = 0;
  while (dut.Next()) ++n;
  EXPECT_EQ(n, dut.route().size());
  EXPECT_GT(n, 50u);
}

TEST_F(SimCameraTest, RendersDepthWhenAsked) {
  SimCameraOptions options = Small();
  options.scene.depth = true;
  SimCamera dut(options, clock_);
  const auto frame = dut.Next();
  ASSERT_TRUE(frame.has_value());
  const cv::Mat& depth = frame->observation.depth_m;
  ASSERT_EQ(depth.type(), CV_32F);
  EXPECT_EQ(depth.size(), frame->observation.bgr.size());
  double lo = 0.0, hi = 0.0;
  cv::minMaxLoc(depth, &lo, &hi);
  EXPECT_GE(lo, 0.0);
  EXPECT_GT(hi, 0.5);
  EXPECT_LT(hi, 100.0);

  SimCamera no_depth(Small(), clock_);
  EXPECT_TRUE(no_depth.Next()->observation.depth_m.empty());
}

TEST_F(SimCameraTest, DimLightingIsDarkerThanDay) {
  SimCameraOptions dim = Small();
  dim.scene.lighting = sim::LightingMode::kDim;
  SimCamera day_camera(Small(), clock_), dim_camera(dim, clock_);
  EXPECT_LT(cv::mean(dim_camera.Next()->observation.bgr)[1],
            cv::mean(day_camera.Next()->observation.bgr)[1]);
}

TEST_F(SimCameraTest, TeamRobotsFollowDifferentRoutesInOneWorld) {
  SimCameraOptions first = Small(), second = Small();
  first.scene.robots = second.scene.robots = 2;
  second.robot = 1;
  SimCamera a(first, clock_), b(second, clock_);
  EXPECT_EQ(a.world().rooms().size(), b.world().rooms().size());
  EXPECT_NE(a.route().size(), 0u);
  const bool same_start =
      a.start_pose().x == b.start_pose().x && a.start_pose().y == b.start_pose().y;
  const bool same_length = a.route().size() == b.route().size();
  EXPECT_FALSE(same_start && same_length);
  EXPECT_EQ(b.name(), "sim:office/7/route 1");
}

TEST_F(SimCameraTest, RouteOutsideTeamIsRejected) {
  SimCameraOptions options = Small();
  options.scene.robots = 2;
  options.robot = 2;
  try {
    SimCamera dut(options, clock_);
    FAIL() << "route 2 of a team of 2 must be rejected";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("route 2"), std::string::npos) << e.what();
  }
}

TEST_F(SimCameraTest, RendersFromBasePoseAsItMoves) {
  SimCameraOptions options = Small();
  options.scene.jitter_heading_deg = 0.0;
  options.scene.jitter_position_m = 0.0;
  options.scene.glitch_probability = 0.0;
  const SimCamera scripted(options, clock_);
  SimBaseOptions base_options;
  base_options.start_x_m = scripted.start_pose().x;
  base_options.start_y_m = scripted.start_pose().y;
  base_options.start_heading_rad = scripted.start_pose().heading;
  SimBase base(base_options, clock_);
  SimCamera dut(options, base, clock_);
  EXPECT_EQ(dut.name(), "sim:office/7/base");

  const cv::Mat before = dut.Next().value().observation.bgr;
  EXPECT_DOUBLE_EQ(dut.last().pose.x, scripted.start_pose().x);
  EXPECT_EQ(dut.last().label, dut.world().LabelAt(base_options.start_x_m, base_options.start_y_m));
  // Turn in place by 90°: the view changes, the position does not.
  for (int i = 0; i < 10; ++i) {
    base.Command({0.0, 1.5707963, false});
    clock_.Advance(100'000);
  }
  const cv::Mat after = dut.Next().value().observation.bgr;
  EXPECT_NEAR(dut.last().pose.x, scripted.start_pose().x, 1e-9);
  EXPECT_GT(Difference(before, after), 0.0);
}

TEST_F(SimCameraTest, PacesToFps) {
  SimCameraOptions options = Small();
  options.fps = 20.0;
  SimCamera dut(options, clock_);
  const int64_t t0 = dut.Next()->utime, t1 = dut.Next()->utime, t2 = dut.Next()->utime;
  EXPECT_EQ(t1 - t0, 50'000);
  EXPECT_EQ(t2 - t1, 50'000);
}

}  // namespace
}  // namespace tsc

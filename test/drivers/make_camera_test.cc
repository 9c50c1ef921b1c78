#include "drivers/camera/make_camera.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "drivers/clock.h"

namespace tsc {
namespace {

/// The CameraError MakeCamera throws for these settings ("" when it does not throw).
std::string ErrorOf(const CameraOptions& camera, const SimOptions& sim, bool* recoverable) {
  try {
    ManualClock clock;
    MakeCamera(camera, sim, nullptr, false, clock);
  } catch (const CameraError& e) {
    *recoverable = e.recoverable();
    return e.what();
  }
  return "";
}

SimOptions SmallSim() {
  SimOptions sim;
  sim.width = 32;
  sim.height = 24;
  return sim;
}

TEST(MakeCamera, UnknownSourceIsFatalErrorNamingTheKey) {
  CameraOptions camera;
  camera.source = "webcam";
  bool recoverable = true;
  const std::string error = ErrorOf(camera, SmallSim(), &recoverable);
  EXPECT_FALSE(recoverable);
  EXPECT_NE(error.find("camera.source 'webcam'"), std::string::npos) << error;
}

TEST(MakeCamera, FileSourcesWithoutPathAreFatalErrors) {
  for (const char* source : {"folder", "video", "device"}) {
    CameraOptions camera;
    camera.source = source;
    bool recoverable = true;
    const std::string error = ErrorOf(camera, SmallSim(), &recoverable);
    EXPECT_FALSE(recoverable) << source;
    EXPECT_NE(error.find("camera.path"), std::string::npos) << error;
  }
}

TEST(MakeCamera, MissingFilesAreFatalErrorsNamingThem) {
  for (const char* source : {"folder", "video", "device"}) {
    CameraOptions camera;
    camera.source = source;
    camera.path = "/nonexistent/tscd-camera";
    bool recoverable = true;
    const std::string error = ErrorOf(camera, SmallSim(), &recoverable);
    EXPECT_FALSE(recoverable) << source;
    EXPECT_NE(error.find("/nonexistent/tscd-camera"), std::string::npos) << error;
  }
}

TEST(MakeCamera, BadSimSettingsAreFatalErrorsNamingTheKey) {
  SimOptions sim = SmallSim();
  sim.lighting = "dusk";
  bool recoverable = true;
  std::string error = ErrorOf(CameraOptions{}, sim, &recoverable);
  EXPECT_FALSE(recoverable);
  EXPECT_NE(error.find("sim.lighting"), std::string::npos) << error;

  sim = SmallSim();
  sim.team_size = 2;
  sim.route = 3;
  error = ErrorOf(CameraOptions{}, sim, &recoverable);
  EXPECT_NE(error.find("route 3"), std::string::npos) << error;
}

TEST(MakeCamera, SimIsTheDefaultSource) {
  ManualClock clock;
  const auto dut = MakeCamera(CameraOptions{}, SmallSim(), nullptr, true, clock);
  EXPECT_EQ(dut->name(), "sim:office/1/route 0");
  const auto frame = dut->Next();
  ASSERT_TRUE(frame.has_value());
  EXPECT_EQ(frame->observation.bgr.cols, 32);
  EXPECT_FALSE(frame->observation.depth_m.empty());
}

TEST(MakeCamera, SimBaseStartsWhereTheSimCameraRouteStarts) {
  ManualClock clock;
  const SimOptions sim = SmallSim();
  const SimBaseOptions base_options = ToSimBaseOptions(sim);
  SimBase base(base_options, clock);
  const auto dut = MakeCamera(CameraOptions{}, sim, &base, false, clock);
  EXPECT_EQ(dut->name(), "sim:office/1/base");
  const SimCamera scripted(ToSimCameraOptions(CameraOptions{}, sim), clock);
  EXPECT_DOUBLE_EQ(base_options.start_x_m, scripted.start_pose().x);
  EXPECT_DOUBLE_EQ(base_options.start_y_m, scripted.start_pose().y);
  EXPECT_TRUE(dut->Next().has_value());
}

TEST(MakeCamera, FolderSourceReadsDataset) {
  const std::filesystem::path data = std::filesystem::path(TSCD_DATA_DIR) / "rtabmap-loop";
  if (!std::filesystem::exists(data)) GTEST_SKIP() << data << " not present";
  CameraOptions camera;
  camera.source = "folder";
  camera.path = data.string();
  ManualClock clock;
  const auto dut = MakeCamera(camera, SmallSim(), nullptr, false, clock);
  EXPECT_EQ(dut->name(), "folder:" + data.string());
  EXPECT_EQ(dut->intrinsics().width(), 512);
}

}  // namespace
}  // namespace tsc

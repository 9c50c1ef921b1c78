#include "drivers/camera/video_camera.h"

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <opencv2/videoio.hpp>
#include <string>
#include <thread>

#include "drivers/clock.h"
#include "test/support/temp_dir.h"

namespace tsc {
namespace {
namespace fs = std::filesystem;

constexpr int kWidth = 96;
constexpr int kHeight = 64;
constexpr int kFrames = 6;

class VideoCameraTest : public ::testing::Test {
 protected:
  void SetUp() override {
    cv::VideoWriter writer(file_.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10.0,
                           cv::Size(kWidth, kHeight), true);
    ASSERT_TRUE(writer.isOpened()) << "no MJPG AVI writer in this OpenCV";
    for (int i = 0; i < kFrames; ++i) {
      writer.write(cv::Mat(kHeight, kWidth, CV_8UC3, cv::Scalar(30 * i, 128, 200)));
    }
  }
  VideoCameraOptions Options() const {
    VideoCameraOptions options;
    options.file = file_;
    options.fps = 0.0;
    options.hfov_deg = 90.0;
    return options;
  }
  testing_support::TempDir temp_{"tscd_video_camera_test"};
  fs::path file_ = temp_.path() / "clip.avi";
  ManualClock clock_;
};

TEST_F(VideoCameraTest, RoundTripDeliversEveryFrameAtItsSize) {
  VideoCamera dut(Options(), clock_);
  EXPECT_EQ(dut.intrinsics().width(), kWidth);
  EXPECT_EQ(dut.intrinsics().height(), kHeight);
  EXPECT_NEAR(dut.intrinsics().fx(), kWidth / 2.0, 1e-9);
  int n = 0;
  while (auto frame = dut.Next()) {
    const cv::Mat& bgr = frame->observation.bgr;
    EXPECT_EQ(bgr.type(), CV_8UC3);
    EXPECT_EQ(bgr.cols, kWidth);
    EXPECT_EQ(bgr.rows, kHeight);
    EXPECT_NEAR(bgr.at<cv::Vec3b>(kHeight / 2, kWidth / 2)[0], 30 * n, 8) << "frame " << n;
    EXPECT_EQ(frame->sequence, n);
    ++n;
  }
  EXPECT_EQ(n, kFrames);
  EXPECT_EQ(dut.name(), "video:" + file_.string());
}

// Issue 18: a video whose container declares frames larger than camera.max_image_pixels is
// refused when opened, naming the file and the declared size, before a frame is decoded.
TEST_F(VideoCameraTest, FramesLargerThanTheLimitAreRefusedAtOpenNamingTheSize) {
  VideoCameraOptions options = Options();
  options.max_image_pixels = kWidth * kHeight - 1;
  try {
    VideoCamera dut(options, clock_);
    FAIL() << "a video over the limit must not open";
  } catch (const CameraError& e) {
    EXPECT_FALSE(e.recoverable());
    const std::string what = e.what();
    EXPECT_NE(what.find(file_.string()), std::string::npos) << what;
    EXPECT_NE(what.find("96x64"), std::string::npos) << what;
    EXPECT_NE(what.find("camera.max_image_pixels"), std::string::npos) << what;
  }
  options.max_image_pixels = kWidth * kHeight;  // inclusive
  EXPECT_NO_THROW(VideoCamera(options, clock_));
}

TEST_F(VideoCameraTest, LoopsAfterLastFrameWhenAsked) {
  VideoCameraOptions options = Options();
  options.loop = true;
  VideoCamera dut(options, clock_);
  for (int i = 0; i < kFrames; ++i) ASSERT_TRUE(dut.Next().has_value());
  const auto again = dut.Next();
  ASSERT_TRUE(again.has_value());
  EXPECT_NEAR(again->observation.bgr.at<cv::Vec3b>(kHeight / 2, kWidth / 2)[0], 0, 8);
  EXPECT_EQ(again->sequence, kFrames);
}

TEST_F(VideoCameraTest, PacesTimestampsToFps) {
  VideoCameraOptions options = Options();
  options.fps = 25.0;
  VideoCamera dut(options, clock_);
  const int64_t t0 = dut.Next()->utime;
  const int64_t t1 = dut.Next()->utime;
  EXPECT_EQ(t1 - t0, 40'000);
}

TEST_F(VideoCameraTest, MissingFileIsFatalErrorNamingIt) {
  VideoCameraOptions options = Options();
  options.file = temp_.path() / "missing.avi";
  try {
    VideoCamera dut(options, clock_);
    FAIL() << "a missing file must throw";
  } catch (const CameraError& e) {
    EXPECT_FALSE(e.recoverable());
    EXPECT_NE(std::string(e.what()).find("missing.avi"), std::string::npos) << e.what();
  }
}

TEST_F(VideoCameraTest, UndecodableFileIsFatalError) {
  const fs::path junk = temp_.path() / "junk.avi";
  {
    std::FILE* f = std::fopen(junk.string().c_str(), "wb");
    ASSERT_NE(f, nullptr);
    std::fputs("this is not a video", f);
    std::fclose(f);
  }
  VideoCameraOptions options = Options();
  options.file = junk;
  EXPECT_THROW(VideoCamera(options, clock_), CameraError);
}

// Stopping does not wait for the next frame: at 0.01 frames per second Interrupt() ends the
// 100 s wait at once.
TEST_F(VideoCameraTest, InterruptEndsTheWaitForTheNextFrame) {
  VideoCameraOptions options = Options();
  options.fps = 0.01;
  VideoCamera dut(options);  // the real clock
  ASSERT_TRUE(dut.Next().has_value());
  std::optional<CameraFrame> second{CameraFrame{}};
  std::thread reader([&] { second = dut.Next(); });
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  dut.Interrupt();
  reader.join();
  // No clock is asserted: had Interrupt() not ended the wait, Next() would have returned the
  // second frame after 100 s rather than nothing.
  EXPECT_FALSE(second.has_value());
  EXPECT_FALSE(dut.Next().has_value());
}

}  // namespace
}  // namespace tsc

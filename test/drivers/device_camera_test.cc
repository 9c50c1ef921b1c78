// No camera is attached where the tests run: the V4L2 path is exercised for its errors, the
// reconnection logic over a fake device that can be unplugged.
#include "drivers/camera/device_camera.h"

#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "drivers/clock.h"
#include "test/support/image_bombs.h"

namespace tsc {
namespace {

using namespace testing_support;

/// A 30 fps camera on a ManualClock: every Grab() takes one frame period.
struct FakeDeviceState {
  ManualClock* clock = nullptr;
  bool plugged = true;
  int open_calls = 0;
  int grabs = 0;
};

class FakeDevice : public VideoDevice {
 public:
  explicit FakeDevice(FakeDeviceState* state) : state_(state) {}
  bool Open() override {
    ++state_->open_calls;
    open_ = state_->plugged;
    return open_;
  }
  void Close() override { open_ = false; }
  bool IsOpen() const override { return open_; }
  bool Grab() override {
    if (!open_ || !state_->plugged) return false;
    state_->clock->Advance(33'333);
    ++state_->grabs;
    return true;
  }
  bool Retrieve(cv::Mat* frame) override {
    *frame = cv::Mat(48, 64, CV_8UC3, cv::Scalar(state_->grabs % 256, 0, 0));
    return true;
  }
  cv::Size FrameSize() const override { return {64, 48}; }

 private:
  FakeDeviceState* state_;
  bool open_ = false;
};

class DeviceCameraTest : public ::testing::Test {
 protected:
  DeviceCameraOptions Options(double fps) const {
    DeviceCameraOptions options;
    options.device = "/dev/fake0";
    options.fps = fps;
    options.hfov_deg = 90.0;
    return options;
  }
  ManualClock clock_;
  FakeDeviceState state_{&clock_};
};

TEST_F(DeviceCameraTest, DeliversNewestFrameAtFpsDroppingTheRest) {
  DeviceCamera dut(Options(10.0), std::make_unique<FakeDevice>(&state_), clock_);
  EXPECT_EQ(dut.intrinsics().width(), 64);
  EXPECT_NEAR(dut.intrinsics().fx(), 32.0, 1e-9);
  std::vector<int64_t> stamps;
  for (int i = 0; i < 5; ++i) {
    const auto frame = dut.Next();
    ASSERT_TRUE(frame.has_value());
    EXPECT_EQ(frame->sequence, i);
    EXPECT_EQ(frame->observation.bgr.type(), CV_8UC3);
    stamps.push_back(frame->utime);
  }
  for (size_t i = 1; i < stamps.size(); ++i) {
    EXPECT_GE(stamps[i] - stamps[i - 1], 99'000);
    EXPECT_LE(stamps[i] - stamps[i - 1], 134'000);
  }
  EXPECT_GE(state_.grabs, 12);  // ~3 grabs per delivered frame
}

TEST_F(DeviceCameraTest, UnpluggedDeviceIsRecoverableAndReopensWithBoundedBackoff) {
  DeviceCamera dut(Options(0.0), std::make_unique<FakeDevice>(&state_), clock_);
  ASSERT_TRUE(dut.Next().has_value());
  state_.plugged = false;
  try {
    dut.Next();
    FAIL() << "an unplugged device must throw";
  } catch (const CameraError& e) {
    EXPECT_TRUE(e.recoverable());
    EXPECT_NE(std::string(e.what()).find("device:/dev/fake0"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(dut.is_open());
  // Each later call waits out the backoff, tries once, and doubles the wait up to 5 s.
  std::vector<int64_t> waits;
  for (int i = 0; i < 6; ++i) {
    const int64_t before = clock_.SteadyMicros();
    EXPECT_THROW(dut.Next(), CameraError);
    waits.push_back(clock_.SteadyMicros() - before);
  }
  EXPECT_EQ(waits,
            (std::vector<int64_t>{500'000, 1'000'000, 2'000'000, 4'000'000, 5'000'000, 5'000'000}));
  state_.plugged = true;
  const auto frame = dut.Next();
  ASSERT_TRUE(frame.has_value());
  EXPECT_EQ(frame->sequence, 1);
  EXPECT_EQ(dut.backoff_us(), 500'000);
}

// Stopping does not wait out a reconnect backoff (up to camera.reconnect_max_s): Interrupt()
// from another thread ends it, and Next() returns nullopt.
TEST_F(DeviceCameraTest, InterruptEndsTheReconnectWait) {
  DeviceCameraOptions options = Options(0.0);
  options.reopen_min_s = 100.0;
  options.reopen_max_s = 100.0;
  DeviceCamera dut(options, std::make_unique<FakeDevice>(&state_));  // the real clock
  ASSERT_TRUE(dut.Next().has_value());
  state_.plugged = false;
  EXPECT_THROW(dut.Next(), CameraError);  // lost: the next call waits 100 s before reopening
  std::optional<CameraFrame> next{CameraFrame{}};
  std::thread reader([&] { next = dut.Next(); });
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  dut.Interrupt();
  reader.join();
  // No clock is asserted: had Interrupt() not ended the wait, Next() would have reopened the
  // device after 100 s (a second open call) rather than returned nothing.
  EXPECT_FALSE(next.has_value());
  EXPECT_EQ(state_.open_calls, 1);  // no reopen attempted
}

/// An MJPEG device handing over its frames undecoded (as V4L2 does with CAP_PROP_CONVERT_RGB
/// off): JPEG bytes in one row; frame `bomb_at` is a forged header claiming 20512x35225.
class MjpegDevice : public VideoDevice {
 public:
  explicit MjpegDevice(int bomb_at) : bomb_at_(bomb_at) {}
  bool Open() override { return open_ = true; }
  void Close() override { open_ = false; }
  bool IsOpen() const override { return open_; }
  bool Grab() override { return open_; }
  bool Retrieve(cv::Mat* frame) override {
    const std::vector<uint8_t> bytes =
        retrieved_++ == bomb_at_ ? ForgedJpegBomb() : EncodeImage(".jpg", 64, 48);
    *frame = cv::Mat(1, static_cast<int>(bytes.size()), CV_8UC1);
    std::copy(bytes.begin(), bytes.end(), frame->ptr<uint8_t>());
    return true;
  }
  cv::Size FrameSize() const override { return {64, 48}; }

 private:
  int bomb_at_;
  int retrieved_ = 0;
  bool open_ = false;
};

TEST_F(DeviceCameraTest, CompressedFramesAreDecodedAndABombIsRefusedBeforeDecoding) {
  DeviceCamera dut(Options(0.0), std::make_unique<MjpegDevice>(2), clock_);
  for (int i = 0; i < 2; ++i) {
    const auto frame = dut.Next();
    ASSERT_TRUE(frame.has_value());
    EXPECT_EQ(frame->observation.bgr.size(), cv::Size(64, 48));
    EXPECT_EQ(frame->observation.bgr.type(), CV_8UC3);
  }
  const bool can_measure = ResetPeakRss();
  const long before_kb = RssKb();
  try {
    dut.Next();
    FAIL() << "a frame claiming 20512x35225 must be refused";
  } catch (const CameraError& e) {
    EXPECT_TRUE(e.recoverable());
    const std::string what = e.what();
    EXPECT_NE(what.find("device:/dev/fake0: frame 2"), std::string::npos) << what;
    EXPECT_NE(what.find("20512x35225"), std::string::npos) << what;
  }
  if (can_measure) {
    EXPECT_LT(PeakRssKb() - before_kb, 20 * 1024);  // decoding it would take 2.1 GB
  }
  EXPECT_TRUE(dut.is_open());  // a bad frame is not a lost device
  const auto after = dut.Next();
  ASSERT_TRUE(after.has_value());
  EXPECT_EQ(after->sequence, 2);  // the refused frame is not delivered
}

TEST_F(DeviceCameraTest, MissingDeviceIsFatalErrorNamingIt) {
  DeviceCameraOptions options;
  options.device = "/dev/video99";
  try {
    DeviceCamera dut(options);
    FAIL() << "a missing device must throw";
  } catch (const CameraError& e) {
    EXPECT_FALSE(e.recoverable());
    EXPECT_NE(std::string(e.what()).find("/dev/video99"), std::string::npos) << e.what();
  }
}

TEST_F(DeviceCameraTest, MissingDeviceIndexIsFatalErrorNamingIt) {
  DeviceCameraOptions options;
  options.device = "99";
  try {
    DeviceCamera dut(options);
    FAIL() << "a missing device must throw";
  } catch (const CameraError& e) {
    EXPECT_FALSE(e.recoverable());
    EXPECT_NE(std::string(e.what()).find("device:99"), std::string::npos) << e.what();
  }
}

TEST_F(DeviceCameraTest, NonDeviceFileIsFatalError) {
  DeviceCameraOptions options;
  options.device = "/dev/null";
  EXPECT_THROW(DeviceCamera dut(options), CameraError);
}

TEST_F(DeviceCameraTest, BadOptionsAreRejectedNamingTheField) {
  DeviceCameraOptions options;
  options.device = "/dev/video0";
  options.reopen_min_s = 10.0;
  options.reopen_max_s = 5.0;
  try {
    options.Validate();
    FAIL() << "min backoff above max must be rejected";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("backoff"), std::string::npos) << e.what();
  }
  options = DeviceCameraOptions{};
  EXPECT_THROW(options.Validate(), std::invalid_argument);  // no device named
}

}  // namespace
}  // namespace tsc

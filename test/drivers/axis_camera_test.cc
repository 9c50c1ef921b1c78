// The Axis camera driver against the simulated Axis camera (tools/simulators/axis_sim) over real
// TCP on 127.0.0.1 with ephemeral ports: MJPEG frames decode and show the simulated world at the
// camera's pan, PTZ moves and queries, 401 without credentials and success with Basic and
// Digest, reconnection after the server drops the stream, and a 360° PTZ sweep that fills
// the bubble surface with a heading-invariant descriptor.

#include "drivers/camera/axis_camera.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <boost/asio/error.hpp>
#include <chrono>
#include <cmath>
#include <fstream>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "core/bubble/descriptor.h"
#include "core/pipeline/pipeline.h"
#include "drivers/camera/camera_options.h"
#include "drivers/camera/make_camera.h"
#include "test/support/temp_dir.h"
#include "tools/simulators/axis_sim.h"

namespace tsc {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

AxisCameraOptions CameraFor(const AxisSim& sim) {
  AxisCameraOptions o;
  o.host = "127.0.0.1";
  o.port = sim.port();
  o.width = 160;
  o.height = 120;
  o.fps = 30;
  o.hfov_deg = 60;
  o.settle_s = 0.05;
  o.timeout_s = 3;
  o.reconnect_min_s = 0.05;
  o.reconnect_max_s = 0.2;
  return o;
}

AxisSimOptions SimConfig(const std::string& auth = "none") {
  AxisSimOptions o;
  o.world_seed = 3;
  o.auth = auth;
  o.user = "root";
  o.password = auth == "none" ? "" : "s3cret";
  return o;
}

// The centre of room `i` of the simulator's world (seed 3), heading `heading`.
sim::Pose2 RoomCentre(size_t i, double heading) {
  sim::SimOptions s;
  s.seed = 3;
  const sim::Room& room = sim::MakeScenario(s).world.rooms().at(i);
  return {room.cx(), room.cy(), heading};
}

// The frame the simulator renders at `pose`, for comparing with what the driver delivers.
cv::Mat Rendered(sim::Pose2 pose, double axis_pan_deg) {
  sim::SimOptions s;
  s.seed = 3;
  const sim::Scenario scenario = sim::MakeScenario(s);
  sim::RenderOptions r;
  r.width = 160;
  r.height = 120;
  r.hfov_deg = 60;
  const sim::Renderer renderer(scenario.world, r, 1u);
  pose.heading -= axis_pan_deg * kDeg;
  cv::Mat bgr;
  renderer.Render(pose, &bgr, nullptr);
  return bgr;
}

double MeanAbsDiff(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat d;
  cv::absdiff(a, b, d);
  const cv::Scalar m = cv::mean(d);
  return (m[0] + m[1] + m[2]) / 3.0;
}

TEST(AxisCamera, MjpegFramesDecodeAndShowTheWorldAtTheCameraPan) {
  AxisSim sim(SimConfig());
  const sim::Pose2 pose = RoomCentre(0, 0.5);
  sim.SetPose(pose);
  AxisCameraOptions options = CameraFor(sim);
  options.compression = 0;  // JPEG quality 100: the pixels are the simulator's
  AxisCamera dut(options);
  dut.MoveAbsolute(30.0, 0.0);
  for (int i = 0; i < 5; ++i) {
    const std::optional<CameraFrame> frame = dut.Next();
    ASSERT_TRUE(frame);
    EXPECT_EQ(frame->sequence, i);
    EXPECT_TRUE(frame->ends_base_point);
    ASSERT_EQ(frame->observation.bgr.size(), cv::Size(160, 120));
    ASSERT_EQ(frame->observation.bgr.type(), CV_8UC3);
    // Axis pan 30° (clockwise) is 30° to the right: −30° in the bubble space.
    EXPECT_NEAR(frame->observation.pan_tilt.pan_rad, -30.0 * kDeg, 1e-6);
    // The simulator's rendering at the robot pose turned by the pan, not at a pan near it.
    const double at_pan = MeanAbsDiff(frame->observation.bgr, Rendered(pose, 30.0));
    EXPECT_LT(at_pan, 4.0);  // JPEG (chroma subsampling) on fine textures
    for (const double other : {0.0, 25.0, 35.0, 120.0}) {
      EXPECT_GT(MeanAbsDiff(frame->observation.bgr, Rendered(pose, other)), 2 * at_pan) << other;
    }
  }
  EXPECT_EQ(dut.connections(), 1);
  EXPECT_EQ(dut.name(), "axis:127.0.0.1:" + std::to_string(sim.port()));
}

TEST(AxisCamera, PartsWithoutContentLengthDecode) {
  AxisSimOptions options = SimConfig();
  options.omit_content_length = true;
  AxisSim sim(options);
  AxisCamera dut(CameraFor(sim));
  for (int i = 0; i < 3; ++i) {
    const std::optional<CameraFrame> frame = dut.Next();
    ASSERT_TRUE(frame);
    EXPECT_EQ(frame->observation.bgr.size(), cv::Size(160, 120));
  }
}

TEST(AxisCamera, PtzMovesAndPositionQuery) {
  AxisSim sim(SimConfig());
  AxisCamera dut(CameraFor(sim));
  dut.MoveAbsolute(45.0, -10.0);
  PtzPosition p = dut.QueryPosition();
  EXPECT_NEAR(p.pan_deg, 45.0, 0.01);
  EXPECT_NEAR(p.tilt_deg, -10.0, 0.01);
  dut.MoveRelative(-90.0, 5.0);
  p = dut.QueryPosition();
  EXPECT_NEAR(p.pan_deg, -45.0, 0.01);
  EXPECT_NEAR(p.tilt_deg, -5.0, 0.01);
  dut.MoveAbsolute(200.0, 0.0);  // wraps to −160
  EXPECT_NEAR(dut.QueryPosition().pan_deg, -160.0, 0.01);
  EXPECT_NEAR(sim.pan_deg(), -160.0, 0.01);
  const PanTilt pt = dut.ToPanTilt(PtzPosition{-160.0, 20.0, 1.0});
  EXPECT_NEAR(pt.pan_rad, 160.0 * kDeg, 1e-9);
  EXPECT_NEAR(pt.tilt_rad, 20.0 * kDeg, 1e-9);
}

TEST(AxisCamera, Answers401WithoutCredentials) {
  for (const std::string auth : {"basic", "digest"}) {
    AxisSim sim(SimConfig(auth));
    AxisCamera dut(CameraFor(sim));
    try {
      dut.Next();
      ADD_FAILURE() << auth << ": a frame without credentials";
    } catch (const CameraError& e) {
      EXPECT_FALSE(e.recoverable());
      EXPECT_NE(std::string(e.what()).find("401"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("camera.axis_user"), std::string::npos) << e.what();
    }
    EXPECT_THROW(dut.QueryPosition(), CameraError);
    EXPECT_GE(sim.unauthorized(), 2);
    EXPECT_EQ(sim.frames_served(), 0);
  }
}

TEST(AxisCamera, SucceedsWithBasicAndDigestCredentialsAndRejectsAWrongPassword) {
  for (const std::string auth : {"basic", "digest"}) {
    AxisSim sim(SimConfig(auth));
    AxisCameraOptions options = CameraFor(sim);
    options.user = "root";
    options.password = "s3cret";
    AxisCamera dut(options);
    for (int i = 0; i < 3; ++i) ASSERT_TRUE(dut.Next()) << auth;
    dut.MoveAbsolute(10.0, 0.0);
    EXPECT_NEAR(dut.QueryPosition().pan_deg, 10.0, 0.01) << auth;
    // One challenge per connection at most: later requests reuse the credentials.
    EXPECT_LE(sim.unauthorized(), 2) << auth;

    options.password = "wrong";
    AxisCamera wrong(options);
    try {
      wrong.Next();
      ADD_FAILURE() << auth << ": a frame with a wrong password";
    } catch (const CameraError& e) {
      EXPECT_FALSE(e.recoverable());
      EXPECT_NE(std::string(e.what()).find("rejected the credentials of user 'root'"),
                std::string::npos)
          << e.what();
    }
  }
}

TEST(AxisCamera, ReconnectsAfterTheServerDropsTheStream) {
  AxisSimOptions options = SimConfig();
  options.drop_after_frames = 3;
  AxisSim sim(options);
  AxisCamera dut(CameraFor(sim));
  int frames = 0, drops = 0;
  while (frames < 8 && drops < 20) {
    try {
      if (dut.Next()) ++frames;
    } catch (const CameraError& e) {
      ASSERT_TRUE(e.recoverable()) << e.what();
      EXPECT_NE(std::string(e.what()).find("reconnecting in"), std::string::npos) << e.what();
      ++drops;
    }
  }
  EXPECT_EQ(frames, 8);
  EXPECT_GE(drops, 2);
  EXPECT_GE(dut.connections(), 3);
  EXPECT_EQ(sim.streams_opened(), dut.connections());
}

// Issue 18: one frame of the MJPEG stream is a JPEG whose header claims 20512x35225 pixels
// (2.2 GB decoded). The driver refuses it from its header (recoverable, naming the camera, the
// frame's number and the claim), stays on the same stream, and delivers the frames after it.
// A non-sweeping camera decodes only the newest of the parts read together, so on a loaded
// machine the bomb can be passed over unread; then a fresh stream serves it again (at most 3).
TEST(AxisCamera, BombFrameIsRefusedByItsHeaderAndTheStreamGoesOn) {
  AxisSimOptions sim_options = SimConfig();
  sim_options.bomb_frame = 1;
  AxisSim sim(sim_options);
  AxisCameraOptions options = CameraFor(sim);
  options.fps = 4;  // parts 250 ms apart: the test takes each as it comes
  int attempts = 0;
  for (; attempts < 3; ++attempts) {
    AxisCamera dut(options);
    int frames = 0;
    std::vector<std::string> errors;
    while (frames < 4 && errors.size() < 3) {
      try {
        const std::optional<CameraFrame> frame = dut.Next();
        ASSERT_TRUE(frame);
        EXPECT_EQ(frame->sequence, frames);
        EXPECT_EQ(frame->observation.bgr.size(), cv::Size(160, 120));
        ++frames;
      } catch (const CameraError& e) {
        errors.push_back(e.what());
        ASSERT_TRUE(e.recoverable()) << e.what();
      }
    }
    EXPECT_EQ(dut.connections(), 1) << "the bomb must not cost the stream";
    if (dut.refused() == 0) continue;  // passed over as stale: not decoded, try again
    ASSERT_EQ(errors.size(), 1u);
    EXPECT_NE(errors[0].find("axis:127.0.0.1:"), std::string::npos) << errors[0];
    EXPECT_NE(errors[0].find("frame 1 of stream 1 "), std::string::npos) << errors[0];
    EXPECT_NE(errors[0].find("claims 20512x35225 pixels"), std::string::npos) << errors[0];
    EXPECT_EQ(frames, 4);
    EXPECT_EQ(dut.refused(), 1);
    break;
  }
  EXPECT_LT(attempts, 3) << "the bomb never reached the decoder";
  EXPECT_GE(sim.bombs_served(), 1);
  std::printf("bomb refused on stream %d\n", attempts + 1);
}

TEST(AxisCamera, BacksOffWhileTheCameraIsGoneAndComesBack) {
  auto sim = std::make_unique<AxisSim>(SimConfig());
  const int port = sim->port();
  AxisCamera dut(CameraFor(*sim));
  ASSERT_TRUE(dut.Next());
  sim.reset();  // the camera goes away
  // Frames already received may still come out; then every call fails, recoverably.
  std::vector<int64_t> backoffs;
  for (int i = 0; i < 20 && backoffs.size() < 5; ++i) {
    try {
      dut.Next();
    } catch (const CameraError& e) {
      EXPECT_TRUE(e.recoverable()) << e.what();
      backoffs.push_back(dut.backoff_us());
    }
  }
  // 50 ms doubling up to the 200 ms cap.
  EXPECT_EQ(backoffs, (std::vector<int64_t>{50'000, 100'000, 200'000, 200'000, 200'000}));
  AxisSimOptions again = SimConfig();
  again.port = port;
  AxisSim back(again);
  std::optional<CameraFrame> frame;
  for (int i = 0; i < 10 && !frame; ++i) {
    try {
      frame = dut.Next();
    } catch (const CameraError& e) {
      ASSERT_TRUE(e.recoverable()) << e.what();
    }
  }
  ASSERT_TRUE(frame);
  EXPECT_EQ(dut.backoff_us(), 50'000);
  EXPECT_EQ(dut.connections(), 2);
}

// Stopping does not wait for a silent camera: a server on 127.0.0.1 that takes the connection
// and never answers holds Next() in its stream read for timeout_s (60 s here); Interrupt()
// from another thread ends it at once (a recoverable error), and later calls return nullopt.
TEST(AxisCamera, InterruptEndsAReadFromASilentCamera) {
  const int listener = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  ASSERT_GE(listener, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t length = sizeof address;
  ASSERT_EQ(::bind(listener, reinterpret_cast<sockaddr*>(&address), length), 0);
  ASSERT_EQ(::listen(listener, 4), 0);  // the kernel completes connections; nobody answers
  ASSERT_EQ(::getsockname(listener, reinterpret_cast<sockaddr*>(&address), &length), 0);
  AxisCameraOptions options;
  options.host = "127.0.0.1";
  options.port = ntohs(address.sin_port);
  options.timeout_s = 60;
  AxisCamera dut(options);
  bool threw = false, returned = false;
  std::string why;
  std::thread reader([&] {
    try {
      returned = dut.Next().has_value();
    } catch (const CameraError& e) {
      threw = e.recoverable();
      why = e.what();
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  dut.Interrupt();
  reader.join();
  EXPECT_TRUE(threw);
  EXPECT_FALSE(returned);
  // Cancelled, not timed out: the read would have ended after 60 s with a timeout too, so the
  // error's reason (not a clock) says that Interrupt() ended it.
  const std::string cancelled =
      boost::asio::error::make_error_code(boost::asio::error::operation_aborted).message();
  EXPECT_NE(why.find(cancelled), std::string::npos) << why;
  EXPECT_FALSE(dut.Next().has_value());
  ::close(listener);
}

// The bubble descriptor of the views of one base point.
struct SweepResult {
  Eigen::VectorXf descriptor;
  int observed = 0;
  std::vector<double> pans;
  std::vector<bool> ends;
};

SweepResult Sweep(AxisSim& sim, const sim::Pose2& pose, int steps) {
  sim.SetPose(pose);
  AxisCameraOptions options = CameraFor(sim);
  options.sweep_steps = steps;
  AxisCamera dut(options);
  const PipelineOptions pipeline;
  BubbleSurface surface(pipeline.features, dut.intrinsics(), pipeline.surface);
  const DescriptorComputer computer(surface.grid(), pipeline.descriptor);
  SweepResult out;
  for (int i = 0; i < steps; ++i) {
    const std::optional<CameraFrame> frame = dut.Next();
    EXPECT_TRUE(frame);
    surface.Observe(frame->observation);
    out.pans.push_back(frame->observation.pan_tilt.pan_rad / kDeg);
    out.ends.push_back(frame->ends_base_point);
  }
  out.observed = surface.ObservedCount();
  out.descriptor = computer.Compute(surface).values();
  return out;
}

TEST(AxisCamera, A360DegreeSweepFillsTheBubbleSurfaceWhateverTheHeading) {
  AxisSim sim(SimConfig());
  const sim::Pose2 base = RoomCentre(0, 0.3);
  const SweepResult single = Sweep(sim, base, 1);
  const SweepResult sweep = Sweep(sim, base, 6);
  // Six views 60° apart, the last one ends the base point; Axis pans 0, 60, ..., 300 → 0,
  // −60, ..., −180, ..., −300 wrapped (the bubble space's pan grows to the left).
  EXPECT_EQ(sweep.ends, (std::vector<bool>{false, false, false, false, false, true}));
  const std::vector<double> expected_pans = {0, -60, -120, -180, 120, 60};
  for (size_t i = 0; i < 6; ++i) EXPECT_NEAR(sweep.pans[i], expected_pans[i], 1e-6) << i;
  // A 60° view covers a sixth of the horizon; the sweep all of it.
  EXPECT_GE(sweep.observed, 5 * single.observed);
  const double to_single = ChiSquared(sweep.descriptor, single.descriptor);

  // The same sweep with the robot turned by one view step: the same six views in another
  // order, i.e. the surface shifted in pan, to which the descriptor is invariant (A.7).
  const SweepResult turned = Sweep(sim, {base.x, base.y, base.heading + 60 * kDeg}, 6);
  const double to_turned = ChiSquared(sweep.descriptor, turned.descriptor);
  // Turned by an angle that is no multiple of the view step nor of the grid spacing: the view
  // borders fall elsewhere, so only the sampling differs.
  const SweepResult odd = Sweep(sim, {base.x, base.y, base.heading + 37 * kDeg}, 6);
  const double to_odd = ChiSquared(sweep.descriptor, odd.descriptor);
  // And somewhere else in the world for scale.
  const SweepResult elsewhere = Sweep(sim, RoomCentre(1, 0.3), 6);
  const double to_elsewhere = ChiSquared(sweep.descriptor, elsewhere.descriptor);
  std::printf(
      "chi2: sweep-single %.5f, sweep-turned60 %.6f, sweep-turned37 %.5f, "
      "sweep-elsewhere %.5f\n",
      to_single, to_turned, to_odd, to_elsewhere);
  EXPECT_LT(to_turned, 1e-4);
  EXPECT_LT(to_odd, 0.25 * to_single);
  EXPECT_LT(to_odd, 0.02);  // below τ_κ: the pipeline sees the same, coherent place
}

TEST(AxisCamera, PasswordFileMustBePrivate) {
  testing_support::TempDir dir("axis_camera_test");
  const std::string file = (dir.path() / "password").string();
  std::ofstream(file) << "s3cret\n";
  ::chmod(file.c_str(), 0644);
  try {
    ReadPasswordFile(file);
    ADD_FAILURE() << "a world-readable password file was accepted";
  } catch (const CameraError& e) {
    EXPECT_NE(std::string(e.what()).find(file), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("0644"), std::string::npos) << e.what();
  }
  ::chmod(file.c_str(), 0600);
  EXPECT_EQ(ReadPasswordFile(file), "s3cret");
  EXPECT_THROW(ReadPasswordFile(file + ".missing"), CameraError);

  CameraOptions camera;
  camera.source = "axis";
  try {
    MakeCamera(camera, tsc::SimOptions{});
    ADD_FAILURE() << "no host";
  } catch (const CameraError& e) {
    EXPECT_NE(std::string(e.what()).find("camera.axis_host"), std::string::npos) << e.what();
  }
  camera.axis_host = "127.0.0.1";
  camera.axis_user = "root";
  camera.axis_password_file = file;
  ::chmod(file.c_str(), 0640);
  try {
    MakeCamera(camera, tsc::SimOptions{});
    ADD_FAILURE() << "group-readable password file";
  } catch (const CameraError& e) {
    EXPECT_NE(std::string(e.what()).find("camera.axis_password_file"), std::string::npos)
        << e.what();
  }
  ::chmod(file.c_str(), 0600);
  EXPECT_EQ(MakeCamera(camera, tsc::SimOptions{})->name(), "axis:127.0.0.1:80");
}

}  // namespace
}  // namespace tsc

#include "drivers/dataset/dataset.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/pipeline/pipeline.h"
#include "drivers/dataset/assumed_keyframes_check.h"
#include "drivers/dataset/base_point_motion.h"
#include "drivers/dataset/base_point_picker.h"
#include "drivers/dataset/base_point_spacing.h"
#include "drivers/dataset/base_point_stride.h"
#include "drivers/dataset/lens_response.h"
#include "drivers/dataset/planar_pose.h"
#include "test/support/image_bombs.h"
#include "test/support/temp_dir.h"

namespace tsc {
namespace {
namespace fs = std::filesystem;

/// A fresh temporary folder per test, removed afterwards.
class DatasetTest : public ::testing::Test {
 protected:
  /// A small image whose top-left pixel encodes `tag`, so tests can tell frames apart.
  static cv::Mat Image(int tag, int w = 32, int h = 24) {
    cv::Mat img(h, w, CV_8UC3, cv::Scalar(40, 80, 120));
    img.at<cv::Vec3b>(0, 0) = cv::Vec3b(static_cast<uint8_t>(tag), 0, 0);
    return img;
  }
  void WriteImage(const fs::path& p, const cv::Mat& img) {
    fs::create_directories(p.parent_path());
    ASSERT_TRUE(cv::imwrite(p.string(), img)) << p;
  }
  void WriteText(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }
  /// Expects Dataset::Open (or `fn`) to throw DatasetError whose message contains `needle`.
  template <typename Fn>
  void ExpectErrorNaming(Fn fn, const std::string& needle) {
    try {
      fn();
      FAIL() << "no DatasetError; expected one naming " << needle;
    } catch (const DatasetError& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos)
          << "message '" << e.what() << "' does not name " << needle;
    }
  }

  testing_support::TempDir temp_{"tscd_dataset_test"};
  fs::path dir_ = temp_.path();
};

TEST(NaturalLess, NumbersCompareByValue) {
  EXPECT_TRUE(NaturalLess("2.jpg", "10.jpg"));
  EXPECT_FALSE(NaturalLess("10.jpg", "2.jpg"));
  EXPECT_TRUE(NaturalLess("frame_9.png", "frame_10.png"));
  EXPECT_TRUE(NaturalLess("a.png", "b.png"));
  EXPECT_TRUE(NaturalLess("img007.png", "img10.png"));
  EXPECT_FALSE(NaturalLess("x.png", "x.png"));
}

TEST_F(DatasetTest, FramesAreInNaturalOrder) {
  for (int i : {10, 2, 1, 33}) WriteImage(dir_ / (std::to_string(i) + ".png"), Image(i));
  WriteText(dir_ / "notes.txt", "not an image");
  const Dataset ds = Dataset::Open(dir_);
  ASSERT_EQ(ds.size(), 4);
  EXPECT_EQ(ds.image_path(0).filename(), "1.png");
  EXPECT_EQ(ds.image_path(1).filename(), "2.png");
  EXPECT_EQ(ds.image_path(2).filename(), "10.png");
  EXPECT_EQ(ds.image_path(3).filename(), "33.png");
  const Observation obs = ds.Load(2).front();
  ASSERT_EQ(obs.bgr.type(), CV_8UC3);
  EXPECT_EQ(obs.bgr.at<cv::Vec3b>(0, 0)[0], 10);
  EXPECT_TRUE(obs.depth_m.empty());
  EXPECT_FALSE(ds.has_depth());
  EXPECT_TRUE(ds.labels().empty());
  EXPECT_TRUE(ds.revisits().empty());
}

TEST_F(DatasetTest, DefaultCameraIs60DegreesAtTheFirstImageSize) {
  WriteImage(dir_ / "1.png", Image(1, 40, 30));
  const Dataset ds = Dataset::Open(dir_);
  EXPECT_EQ(ds.camera().width(), 40);
  EXPECT_EQ(ds.camera().height(), 30);
  // hfov = 2 atan(w / 2 fx)
  EXPECT_NEAR(2 * std::atan(20.0 / ds.camera().fx()) * 180 / std::numbers::pi, 60.0, 1e-6);
}

TEST_F(DatasetTest, FramesInRgbSubfolderWithDepth) {
  for (int i = 1; i <= 3; ++i) {
    WriteImage(dir_ / "rgb" / (std::to_string(i) + ".jpg"), Image(i));
    WriteImage(dir_ / "depth" / (std::to_string(i) + ".png"),
               cv::Mat(24, 32, CV_16UC1, cv::Scalar(1500 * i)));
  }
  const Dataset ds = Dataset::Open(dir_);
  ASSERT_EQ(ds.size(), 3);
  EXPECT_EQ(ds.image_path(0).parent_path().filename(), "rgb");
  ASSERT_TRUE(ds.has_depth());
  const Observation obs = ds.Load(1).front();
  ASSERT_EQ(obs.depth_m.type(), CV_32F);
  EXPECT_FLOAT_EQ(obs.depth_m.at<float>(5, 5), 3.0f);  // 3000 mm
}

TEST_F(DatasetTest, CameraJsonWithFieldOfView) {
  WriteImage(dir_ / "1.png", Image(1, 40, 30));
  WriteText(dir_ / "camera.json", R"({ "width": 40, "height": 30, "hfov_deg": 90, "model": "x" })");
  const Dataset ds = Dataset::Open(dir_);
  EXPECT_NEAR(ds.camera().fx(), 20.0, 1e-9);  // tan(45°) = 20 / fx
}

TEST_F(DatasetTest, CameraJsonWithIntrinsicsScaledToTheImages) {
  WriteImage(dir_ / "1.png", Image(1, 40, 30));
  WriteText(dir_ / "camera.json", R"({"width":80,"height":60,"fx":70.5,"fy":71,"cx":40,"cy":30})");
  const Dataset ds = Dataset::Open(dir_);
  EXPECT_NEAR(ds.camera().fx(), 35.25, 1e-9);
  EXPECT_NEAR(ds.camera().cy(), 14.75, 1e-9);  // pixel-centre convention
}

// How far apart the frames are (DESIGN §3.2 amended): declared in camera.json, else from the
// poses, else a keyframe sequence is assumed.
TEST_F(DatasetTest, SpacingIsDeclaredOrTakenFromThePosesOrKeyframesAreAssumed) {
  for (int i = 1; i <= 4; ++i) WriteImage(dir_ / (std::to_string(i) + ".png"), Image(i, 40, 30));
  EXPECT_DOUBLE_EQ(Dataset::Open(dir_).spacing().metres, kKeyframeSpacingM);
  EXPECT_EQ(Dataset::Open(dir_).spacing().basis, "undeclared: keyframes assumed");

  // Poses: the median step (a turn in place, step 0, does not decide it).
  WriteText(dir_ / "groundtruth.csv",
            "frame,place,x,y,heading\n1,a,0,0,0\n2,a,0.2,0,0\n3,a,0.2,0,1\n4,a,0.4,0,1\n");
  EXPECT_NEAR(Dataset::Open(dir_).spacing().metres, 0.2, 1e-12);

  const std::pair<const char*, double> declared[] = {
      {R"({"hfov_deg": 60, "spacing_m": 0.5})", 0.5},
      {R"({"hfov_deg": 60, "fps": 30})", kAssumedSpeedMps / 30},
      {R"({"hfov_deg": 60, "keyframes": true})", kKeyframeSpacingM}};
  for (const auto& [json, metres] : declared) {
    WriteText(dir_ / "camera.json", json);
    EXPECT_NEAR(Dataset::Open(dir_).spacing().metres, metres, 1e-12) << json;  // over the poses
  }
  for (const char* bad :
       {R"({"hfov_deg": 60, "keyframes": false})", R"({"hfov_deg": 60, "spacing_m": 0})",
        R"({"hfov_deg": 60, "fps": -1})", R"({"hfov_deg": 60, "spacing_m": "1"})",
        R"({"hfov_deg": 60, "fps": 10, "spacing_m": 1})"}) {
    WriteText(dir_ / "camera.json", bad);
    ExpectErrorNaming([&] { Dataset::Open(dir_); }, "camera.json");
  }
}

// Keyframes only assumed (nothing declared how far apart the frames are) while consecutive
// frames change as little as a camera's: the user is told to declare the video's rate. Not
// when keyframes were declared, nor when the frames change as keyframes do (the real loop:
// 0.0102, EvalTest.RtabmapLoopRecognisesWithFullPrecisionAndWritesPlots).
TEST_F(DatasetTest, AssumedKeyframesThatChangeLikeAVideosFramesAreCautioned) {
  for (int i = 1; i <= 2; ++i) WriteImage(dir_ / (std::to_string(i) + ".png"), Image(i, 40, 30));
  const BasePointSpacing assumed = Dataset::Open(dir_).spacing();
  EXPECT_TRUE(assumed.assumed);
  const std::optional<std::string> video = AssumedKeyframesCaution(assumed, 0.0026, CameraLens());
  ASSERT_TRUE(video);
  EXPECT_NE(video->find("declare its \"fps\""), std::string::npos) << *video;
  EXPECT_NE(video->find("0.0026"), std::string::npos) << *video;
  EXPECT_FALSE(AssumedKeyframesCaution(assumed, 0.0102, CameraLens()));
  EXPECT_FALSE(AssumedKeyframesCaution(assumed, kKeyframeChangeChi2, CameraLens()));
  WriteText(dir_ / "camera.json", R"({"hfov_deg": 60, "keyframes": true})");
  const BasePointSpacing declared = Dataset::Open(dir_).spacing();
  EXPECT_TRUE(declared.keyframes);
  EXPECT_FALSE(declared.assumed);
  EXPECT_FALSE(AssumedKeyframesCaution(declared, 0.0026, CameraLens()));
  WriteText(dir_ / "camera.json", R"({"hfov_deg": 60, "fps": 30})");
  EXPECT_FALSE(AssumedKeyframesCaution(Dataset::Open(dir_).spacing(), 0.0026, CameraLens()));
}

// The threshold follows the lens as τ_κ does: a 45° lens's frames change 0.62x as much, so
// the real loop's keyframes seen through it (0.0102 x 0.62) are still keyframes and a 45°
// video's frames (0.0026 x 0.62) still cautioned; a 90° lens's video (0.005 x 1.31) is
// cautioned where the 58° threshold would have taken it for keyframes.
TEST_F(DatasetTest, TheAssumedKeyframesCautionFollowsTheLens) {
  for (int i = 1; i <= 2; ++i) WriteImage(dir_ / (std::to_string(i) + ".png"), Image(i, 40, 30));
  const BasePointSpacing assumed = Dataset::Open(dir_).spacing();
  const CameraLens narrow(45.0, 1), wide(90.0, 1);
  const double narrow_change = ChangeResponse(narrow);
  EXPECT_FALSE(AssumedKeyframesCaution(assumed, 0.0102 * narrow_change, narrow));
  EXPECT_FALSE(AssumedKeyframesCaution(assumed, 0.0045, narrow));
  EXPECT_TRUE(AssumedKeyframesCaution(assumed, 0.0026 * narrow_change, narrow));
  EXPECT_FALSE(AssumedKeyframesCaution(assumed, 0.0055, CameraLens()));
  const std::optional<std::string> video = AssumedKeyframesCaution(assumed, 0.0055, wide);
  ASSERT_TRUE(video);
  EXPECT_NE(video->find("above 0.0065"), std::string::npos) << *video;
}

// The same caution base point by base point (tscd, tsc run): given once, at the base point
// that completes the sample, when the keyframes were only assumed.
TEST(AssumedKeyframesCheckTest, CautionsOnceAfterItsSampleWhenKeyframesWereAssumed) {
  const auto feed = [](const BasePointSpacing& spacing, double step) {
    AssumedKeyframesCheck check(spacing, CameraLens());
    std::vector<int> cautioned;
    Eigen::VectorXf d = Eigen::VectorXf::Constant(100, 0.01f);
    for (int k = 0; k < 3 * AssumedKeyframesCheck::kSample; ++k) {
      // Mass moves by `step` between entries 0 and 1, to and fro.
      const float moved = static_cast<float>(step * (k % 2 == 0 ? 1 : -1));
      d[0] -= moved;
      d[1] += moved;
      if (check.Add(d)) cautioned.push_back(k);
    }
    return cautioned;
  };
  BasePointSpacing assumed{kKeyframeSpacingM, "undeclared: keyframes assumed", true, true};
  // χ² 0.0013 a base point, as a camera's frames change: cautioned once.
  EXPECT_EQ(feed(assumed, 0.005), std::vector<int>{AssumedKeyframesCheck::kSample - 1});
  EXPECT_TRUE(feed(assumed, 0.0095).empty());  // χ² 0.0058: as keyframes change
  BasePointSpacing declared = assumed;
  declared.assumed = false;
  EXPECT_TRUE(feed(declared, 0.005).empty());
}

// A camera whose base points lie further apart than the defaults were calibrated for is told
// so (docs/calibration.md, twenty-first pass); a keyframe sequence, declared or assumed, is not.
TEST_F(DatasetTest, ACameraSparserThanCalibratedIsCautioned) {
  EXPECT_FALSE(SpacingCaution(ResolveSpacing(0.0, nullptr, 10.0)));  // 0.15 m, as calibrated
  EXPECT_FALSE(SpacingCaution(ResolveSpacing(0.0, nullptr, 30.0)));
  EXPECT_FALSE(SpacingCaution(ResolveSpacing(0.2, nullptr, 10.0)));
  const std::optional<std::string> slow = SpacingCaution(ResolveSpacing(0.0, nullptr, 5.0));
  ASSERT_TRUE(slow);
  EXPECT_NE(slow->find("0.3-0.6 m apart"), std::string::npos) << *slow;
  EXPECT_NE(slow->find("twenty-first pass"), std::string::npos) << *slow;
  EXPECT_TRUE(SpacingCaution(ResolveSpacing(0.6, nullptr, 10.0)));  // camera.spacing_m

  for (int i = 1; i <= 2; ++i) WriteImage(dir_ / (std::to_string(i) + ".png"), Image(i, 40, 30));
  EXPECT_TRUE(Dataset::Open(dir_).spacing().keyframes);  // undeclared: keyframes assumed
  EXPECT_FALSE(SpacingCaution(Dataset::Open(dir_).spacing()));
  WriteText(dir_ / "camera.json", R"({"hfov_deg": 60, "keyframes": true})");
  EXPECT_FALSE(SpacingCaution(Dataset::Open(dir_).spacing()));
  WriteText(dir_ / "camera.json", R"({"hfov_deg": 60, "spacing_m": 0.6})");
  EXPECT_FALSE(Dataset::Open(dir_).spacing().keyframes);
  EXPECT_TRUE(SpacingCaution(Dataset::Open(dir_).spacing()));
  WriteText(dir_ / "camera.json", R"({"hfov_deg": 60, "fps": 2})");  // 0.75 m, not keyframes
  EXPECT_TRUE(SpacingCaution(Dataset::Open(dir_).spacing()));
}

// The defaults adapted to a camera's spacing: τ_p counted at it always; τ_w (at least 1) and
// memory.step_unit halved for a sparse camera only, never for a keyframe sequence
// (docs/decisions.md, "Frame rate").
TEST(AdaptToSpacingTest, HalvesTauWAndStepUnitOfASparseCameraOnly) {
  const PipelineOptions configured;
  ASSERT_EQ(configured.detector.tau_w, 2);
  ASSERT_EQ(configured.memory.step_unit, 0.5);
  const auto adapted = [](const BasePointSpacing& spacing, int tau_w = 2) {
    PipelineOptions o;
    o.detector.tau_w = tau_w;
    AdaptToSpacing(o, spacing);
    return o;
  };
  for (const BasePointSpacing& near :
       {ResolveSpacing(0.0, nullptr, 10.0),  // 0.15 m
        ResolveSpacing(0.2, nullptr, 10.0), BasePointSpacing{1.0, "keyframes", true}}) {
    const PipelineOptions o = adapted(near);
    EXPECT_EQ(o.detector.spacing_m, near.metres);
    EXPECT_EQ(o.detector.tau_w, 2) << near.basis;
    EXPECT_EQ(o.memory.step_unit, 0.5) << near.basis;
    EXPECT_FALSE(SparseCameraNote(o, near));
  }
  const BasePointSpacing slow = ResolveSpacing(0.0, nullptr, 5.0);  // 0.3 m
  ASSERT_TRUE(IsSparse(slow));
  const PipelineOptions o = adapted(slow);
  EXPECT_EQ(o.detector.spacing_m, 0.3);
  EXPECT_EQ(o.detector.EffectiveTauP(), 12);  // 3.75 m
  EXPECT_EQ(o.detector.tau_w, 1);
  EXPECT_EQ(o.memory.step_unit, 0.25);
  const std::optional<std::string> note = SparseCameraNote(o, slow);
  ASSERT_TRUE(note);
  EXPECT_NE(note->find("detection.tau_w 1"), std::string::npos) << *note;
  EXPECT_NE(note->find("memory.step_unit 0.25"), std::string::npos) << *note;
  EXPECT_EQ(adapted(slow, 1).detector.tau_w, 1);  // at least one base point
  EXPECT_EQ(adapted(slow, 3).detector.tau_w, 1);
  EXPECT_EQ(adapted(slow, 4).detector.tau_w, 2);
}

// A camera denser than the calibrated spacing gives every stride-th frame as a base point:
// the largest stride that keeps them at most 0.15 m apart, or one more where that leaves them
// closer than 0.1 m (docs/calibration.md, twenty-seventh pass). Keyframes are never thinned.
TEST(StrideForTest, ThinsADenseCameraToTheCalibratedSpacing) {
  const auto stride = [](double fps) { return StrideFor(ResolveSpacing(0.0, nullptr, fps)); };
  EXPECT_EQ(stride(10.0), 1);  // 0.15 m
  EXPECT_EQ(stride(5.0), 1);   // 0.3 m: sparse, adapted otherwise (AdaptToSpacing)
  EXPECT_EQ(stride(15.0), 1);  // 0.1 m: holds as it is
  EXPECT_EQ(stride(17.0), 2);  // 0.088 m → 0.176 m
  EXPECT_EQ(stride(20.0), 2);  // 0.075 m → 0.15 m
  EXPECT_EQ(stride(25.0), 2);  // 0.06 m → 0.12 m
  EXPECT_EQ(stride(30.0), 3);  // 0.05 m → 0.15 m
  EXPECT_EQ(stride(60.0), 6);  // 0.025 m → 0.15 m
  EXPECT_EQ(StrideFor(BasePointSpacing{0.01, "hand-held video"}), 15);
  // Odometry's noise around a quotient does not choose the stride; 2 % off it does.
  EXPECT_EQ(StrideFor(BasePointSpacing{0.0496, "odometry"}), 3);
  EXPECT_EQ(StrideFor(BasePointSpacing{0.0501, "odometry"}), 3);
  EXPECT_EQ(StrideFor(BasePointSpacing{0.0508, "odometry"}), 3);  // 0.152 m
  EXPECT_EQ(StrideFor(BasePointSpacing{0.052, "odometry"}), 2);   // 0.104 m
  EXPECT_EQ(StrideFor(BasePointSpacing{0.0755, "odometry"}), 2);
  EXPECT_EQ(StrideFor(BasePointSpacing{0.01, "keyframes", true}), 1);

  const BasePointSpacing thirty = ResolveSpacing(0.0, nullptr, 30.0);
  const BasePointSpacing taken = EveryNth(thirty, 3);
  EXPECT_NEAR(taken.metres, 0.15, 1e-12);
  EXPECT_FALSE(taken.keyframes);
  EXPECT_NE(taken.basis.find("one in 3 taken"), std::string::npos) << taken.basis;
  EXPECT_EQ(EveryNth(thirty, 1).basis, thirty.basis);
  EXPECT_THROW(EveryNth(thirty, 0), std::invalid_argument);

  // Counted in base points: every view of a pan sweep's base point goes together.
  BasePointStride every_second(2);
  std::vector<bool> took;
  for (int base = 0; base < 4; ++base) {
    for (int view = 0; view < 3; ++view) took.push_back(every_second.Take(view == 2));
  }
  EXPECT_EQ(took, (std::vector<bool>{true, true, true, false, false, false, true, true, true, false,
                                     false, false}));
  EXPECT_THROW(BasePointStride(0), std::invalid_argument);
}

// A robot standing still adds no base points: nothing changes for κ, and a stop in a doorway
// would become a place. The stride's count waits for a frame that moved.
TEST(BasePointMotionTest, ACameraStandingStillGivesNoBasePoints) {
  BasePointMotion motion;
  EXPECT_TRUE(motion.Moved({5.0, 5.0, 1.0}));  // before the first base point
  motion.Taken({0.0, 0.0, 0.0});
  std::mt19937 rng(54);  // fixed seed: a pose jittering by 1 mm and 0.05°
  std::normal_distribution<double> mm(0.0, 0.001);
  std::normal_distribution<double> rad(0.0, 0.0009);
  for (int i = 0; i < 200; ++i) EXPECT_FALSE(motion.Moved({mm(rng), mm(rng), rad(rng)}));
  EXPECT_TRUE(motion.Moved({kStillTravelM, 0.0, 0.0}));
  EXPECT_TRUE(motion.Moved({0.0, 0.0, -kStillTurnDeg * std::numbers::pi / 180.0}));
  motion.Taken({0.0, 0.0, 3.14});  // across ±π
  EXPECT_FALSE(motion.Moved({0.0, 0.0, -3.14}));

  // Every second frame while moving 0.05 m a frame; the robot stops at 0.15 m (frames 3-8):
  // frame 4 is still 0.05 m from the base point at frame 2, then none until frame 9 moved.
  std::vector<std::optional<PlanarPose>> route;
  for (int i = 0; i < 4; ++i) route.push_back(PlanarPose{0.05 * i, 0.0, 0.0});  // 0-3
  for (int i = 0; i < 5; ++i) route.push_back(PlanarPose{0.15, 0.0, 0.0});      // 4-8 stand
  for (int i = 1; i <= 4; ++i) route.push_back(PlanarPose{0.15 + 0.05 * i, 0.0, 0.0});
  EXPECT_EQ(FramesOfRoute(route, 2), (std::vector<int>{0, 2, 4, 9, 11}));
  EXPECT_EQ(FramesOfRoute(route, 1), (std::vector<int>{0, 1, 2, 3, 9, 10, 11, 12}));
  route[5] = std::nullopt;  // a frame without a pose: the route is not picked by its poses
  EXPECT_TRUE(FramesOfRoute(route, 2).empty());
  EXPECT_THROW(FramesOfRoute(route, 0), std::invalid_argument);

  // A sweep's views go together, and a base point taken after a stop keeps all of them.
  BasePointStride stride(1);
  std::vector<bool> took;
  for (const bool moved : {true, false, true}) {
    for (int view = 0; view < 2; ++view) took.push_back(stride.Take(view == 1, moved));
  }
  EXPECT_EQ(took, (std::vector<bool>{true, true, false, false, true, true}));
}

// A live camera on a robot whose odometry gives its speed: the stride follows the measured
// spacing (a robot at 0.5 m/s with a 10 fps camera takes frames 0.05 m apart: one in three),
// not the 1.5 m/s assumed for its frame rate; a robot standing still gives none.
TEST(BasePointPickerTest, TheRobotsMeasuredSpeedSetsTheStride) {
  const auto drive = [](double speed_mps, int frames) {
    BasePointPicker picker(1);  // 10 fps at the assumed 1.5 m/s: every frame
    std::vector<int> taken;
    for (int i = 0; i < frames; ++i) {
      const ViewMotion at{PlanarPose{speed_mps * 0.1 * i, 0.0, 0.0}, speed_mps, 100000LL * i};
      if (picker.Take(true, at)) taken.push_back(i);
    }
    return std::make_pair(taken, picker);
  };
  const auto [slow, slow_picker] = drive(0.5, 26);
  // Every frame until 16 driving steps are measured (frame 16), then one in three.
  std::vector<int> expected;
  for (int i = 0; i <= 16; ++i) expected.push_back(i);
  for (int i = 19; i < 26; i += 3) expected.push_back(i);
  EXPECT_EQ(slow, expected);
  EXPECT_EQ(slow_picker.stride(), 3);
  ASSERT_TRUE(slow_picker.measured_spacing_m());
  EXPECT_NEAR(*slow_picker.measured_spacing_m(), 0.05, 1e-9);
  ASSERT_TRUE(slow_picker.base_point_spacing_m());
  EXPECT_NEAR(*slow_picker.base_point_spacing_m(), 0.15, 1e-9);

  const auto [brisk, brisk_picker] = drive(1.5, 30);
  EXPECT_EQ(brisk.size(), 30u);
  EXPECT_EQ(brisk_picker.stride(), 1);

  // A 10 fps camera on a robot whose speed is Gaussian about `mean_mps` (a fixed seed): the
  // picker's stride after each frame.
  const auto drive_noisy = [](BasePointPicker& picker, double mean_mps, double sd_mps,
                              unsigned seed, int frames) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> speeds(mean_mps, sd_mps);
    std::vector<int> strides;
    double x = 0.0;
    for (int i = 0; i < frames; ++i) {
      const double speed = speeds(rng);
      x += speed * 0.1;
      picker.Take(true, ViewMotion{PlanarPose{x, 0.0, 0.0}, speed, 100000LL * i});
      strides.push_back(picker.stride());
    }
    return strides;
  };

  // At 1 m/s (0.1 m a frame, where StrideFor steps from 1 to 2) the speed's noise does not
  // flip the stride: it stays what it was.
  BasePointPicker edge(1);
  EXPECT_EQ(drive_noisy(edge, 1.0, 0.02, 54, 200), std::vector<int>(200, 1));
  ASSERT_TRUE(edge.measured_spacing_m());
  EXPECT_NEAR(*edge.measured_spacing_m(), 0.1, 0.005);
  ASSERT_TRUE(edge.base_point_spacing_m());
  EXPECT_NEAR(*edge.base_point_spacing_m(), 0.1, 0.005);

  // At 0.5 m/s (0.05 m a frame, which divides 0.15 m) the speed's noise does not choose
  // between one in 2 and one in 3 (StrideFor's quotient tolerance): one in 3 on every seed.
  for (const unsigned seed : {1u, 2u, 3u, 4u, 5u, 6u, 7u, 8u}) {
    BasePointPicker round(1);
    EXPECT_EQ(drive_noisy(round, 0.5, 0.005, seed, 100).back(), 3) << "seed " << seed;
  }

  // Without a speed nothing is measured: the assumed stride stays.
  BasePointPicker unknown(2);
  int taken = 0;
  for (int i = 0; i < 40; ++i) {
    taken +=
        unknown.Take(true, ViewMotion{PlanarPose{0.05 * i, 0.0, 0.0}, std::nullopt, 0}) ? 1 : 0;
  }
  EXPECT_EQ(taken, 20);
  EXPECT_FALSE(unknown.measured_spacing_m());
  EXPECT_FALSE(unknown.base_point_spacing_m());

  // Standing still (speed 0, the pose unchanged): the first base point only, and every view of
  // a sweep goes with its base point.
  BasePointPicker still(1);
  std::vector<bool> views;
  for (int base = 0; base < 3; ++base) {
    for (int view = 0; view < 2; ++view) {
      views.push_back(still.Take(view == 1, ViewMotion{PlanarPose{}, 0.0, 100000LL * base}));
    }
  }
  EXPECT_EQ(views, (std::vector<bool>{true, true, false, false, false, false}));
  EXPECT_TRUE(still.standing());
}

// The base points' spacing by odometry is what detection counts τ_p at (tscd readapts its
// pipeline to it): a 5 fps camera on a robot at 0.5 m/s takes base points 0.1 m apart, not the
// 0.3 m its rate at the assumed 1.5 m/s gave. The spacing moves with the robot's speed only
// once it leaves a fifth either way, so it is not recounted at every base point.
TEST(BasePointPickerTest, TheBasePointsSpacingFollowsTheRobotsSpeedWithHysteresis) {
  BasePointPicker picker(1);  // 5 fps at the assumed 1.5 m/s: 0.3 m, every frame
  double x = 0.0;
  int64_t utime = 0;
  const auto drive = [&](double speed_mps, int frames) {
    for (int i = 0; i < frames; ++i) {
      x += speed_mps * 0.2;
      utime += 200000;
      picker.Take(true, ViewMotion{PlanarPose{x, 0.0, 0.0}, speed_mps, utime});
    }
  };
  drive(0.5, 15);
  EXPECT_FALSE(picker.base_point_spacing_m()) << "measured from 16 driving steps on";
  drive(0.5, 10);
  ASSERT_TRUE(picker.base_point_spacing_m());
  EXPECT_NEAR(*picker.base_point_spacing_m(), 0.1, 1e-9);
  EXPECT_EQ(picker.stride(), 1);
  // 0.55 m/s: 0.11 m, within a fifth of 0.1 m; the adopted spacing stays.
  drive(0.55, 64);
  EXPECT_NEAR(*picker.measured_spacing_m(), 0.11, 1e-9);
  EXPECT_NEAR(*picker.base_point_spacing_m(), 0.1, 1e-9);
  // 1 m/s, the Jaguar's limit: 0.2 m a frame, still every frame; the spacing follows.
  drive(1.0, 64);
  EXPECT_EQ(picker.stride(), 1);
  EXPECT_NEAR(*picker.base_point_spacing_m(), 0.2, 1e-9);
  // 0.25 m/s: 0.05 m a frame, one in three, 0.15 m apart.
  drive(0.25, 64 * 3);
  EXPECT_EQ(picker.stride(), 3);
  EXPECT_NEAR(*picker.base_point_spacing_m(), 0.15, 1e-9);
}

// A camera that stood still for most of its run still has its spacing from the steps it moved.
TEST_F(DatasetTest, SpacingFromPosesIgnoresACameraStandingStill) {
  std::string truth = "frame,place,x,y,heading\n";
  for (int i = 1; i <= 30; ++i) {
    WriteImage(dir_ / (std::to_string(i) + ".png"), Image(i, 40, 30));
    // Frames 1-20 stand at the origin, the pose jittering by a millimetre; then 0.05 m a frame.
    const double x = i <= 20 ? 0.001 * (i % 2) : 0.05 * (i - 20);
    truth += std::to_string(i) + ",a," + std::to_string(x) + ",0,0\n";
  }
  WriteText(dir_ / "groundtruth.csv", truth);
  const Dataset ds = Dataset::Open(dir_);
  EXPECT_NEAR(ds.spacing().metres, 0.05, 1e-9) << ds.spacing().basis;
  // The still frames give one base point, the moving ones one in three from the first.
  const std::vector<int> frames = FramesOfRoute(ds.poses(), 3);
  EXPECT_EQ(frames, (std::vector<int>{0, 20, 23, 26, 29}));
  const Dataset picked = ds.Subset(frames);
  ASSERT_EQ(picked.size(), 5);
  EXPECT_EQ(picked.image_path(1).filename(), "21.png");
  EXPECT_DOUBLE_EQ(picked.poses()[1]->x, 0.05);
  EXPECT_THROW(ds.Subset({3, 2}), std::invalid_argument);
  EXPECT_THROW(ds.Subset({30}), std::invalid_argument);
}

// The frames a dense camera's stride takes, as a dataset: ground truth follows them, and a
// revisit names the taken frame nearest it, when that is earlier.
TEST_F(DatasetTest, EveryNthFrameKeepsItsGroundTruth) {
  for (int i = 1; i <= 7; ++i) WriteImage(dir_ / (std::to_string(i) + ".png"), Image(i));
  WriteText(dir_ / "camera.json", R"({"hfov_deg": 60, "spacing_m": 0.05})");
  WriteText(dir_ / "groundtruth.csv",
            "frame,place,x,y,heading\n1,a,0,0,0\n2,a,0.05,0,0\n3,a,0.1,0,0\n4,b,0.15,0,0\n"
            "5,b,0.2,0,0\n6,b,0.25,0,0\n7,a,0,0,3\n");
  WriteText(dir_ / "revisits.csv", "frame,revisits\n7,2 3\n5,4\n");
  const Dataset all = Dataset::Open(dir_);
  const Dataset taken = all.EveryNth(3);  // frames 1, 4, 7
  ASSERT_EQ(taken.size(), 3);
  EXPECT_EQ(taken.image_path(1).filename(), "4.png");
  EXPECT_EQ(taken.image_path(2), all.image_path(6));
  EXPECT_EQ(taken.labels(), (std::vector<std::string>{"a", "b", "a"}));
  ASSERT_EQ(taken.poses().size(), 3u);
  EXPECT_DOUBLE_EQ(taken.poses()[1]->x, 0.15);
  ASSERT_EQ(taken.revisits().size(), 3u);
  // Frame 7 revisits 2 and 3, whose nearest taken frame is 1 (taken index 0) and 4 (index 1).
  EXPECT_EQ(taken.revisits()[2], (std::vector<int>{0, 1}));
  EXPECT_TRUE(taken.revisits()[1].empty());  // frame 5 is not taken
  EXPECT_NEAR(taken.spacing().metres, 0.15, 1e-12);
  EXPECT_EQ(all.EveryNth(1).size(), 7);
  EXPECT_THROW(all.EveryNth(0), std::invalid_argument);
}

TEST_F(DatasetTest, BadCameraJsonNamesTheFile) {
  WriteImage(dir_ / "1.png", Image(1));
  WriteText(dir_ / "camera.json", R"({"width": 32, "height": )");
  ExpectErrorNaming([&] { Dataset::Open(dir_); }, "camera.json");
  WriteText(dir_ / "camera.json", R"({"width": 32, "height": 24})");
  ExpectErrorNaming([&] { Dataset::Open(dir_); }, "camera.json");
  // A size beyond int's range (found by fuzz_dataset_camera_json) is refused before it is
  // converted, as is a fractional one.
  WriteText(dir_ / "camera.json", R"({"width": 3e22, "height": 24, "hfov_deg": 60})");
  ExpectErrorNaming([&] { Dataset::Open(dir_); }, "camera.json");
  WriteText(dir_ / "camera.json", R"({"width": 32, "height": 23.5, "hfov_deg": 60})");
  ExpectErrorNaming([&] { Dataset::Open(dir_); }, "camera.json");
}

TEST_F(DatasetTest, GroundTruthAndRevisits) {
  for (int i = 1; i <= 5; ++i) WriteImage(dir_ / (std::to_string(i) + ".png"), Image(i));
  WriteText(dir_ / "groundtruth.csv",
            "frame,place,x,y,heading\n1,kitchen,0,0,0\n2,kitchen,1.5,0,0.1\n3,,2,0,0\n"
            "5,hall,3,1,1.57\n");
  WriteText(dir_ / "revisits.csv", "frame,revisits\n1,\n2,\n3,\n4,1 2\n5,3\n");
  const Dataset ds = Dataset::Open(dir_);
  ASSERT_EQ(ds.labels().size(), 5u);
  EXPECT_EQ(ds.labels()[0], "kitchen");
  EXPECT_EQ(ds.labels()[2], "");
  EXPECT_EQ(ds.labels()[3], "");  // not listed
  EXPECT_EQ(ds.labels()[4], "hall");
  ASSERT_EQ(ds.poses().size(), 5u);
  ASSERT_TRUE(ds.poses()[1].has_value());
  EXPECT_DOUBLE_EQ(ds.poses()[1]->x, 1.5);
  EXPECT_FALSE(ds.poses()[3].has_value());
  ASSERT_EQ(ds.revisits().size(), 5u);
  EXPECT_TRUE(ds.revisits()[0].empty());
  EXPECT_EQ(ds.revisits()[3], (std::vector<int>{0, 1}));
  EXPECT_EQ(ds.revisits()[4], (std::vector<int>{2}));
}

TEST_F(DatasetTest, LabelsOnlyGroundTruth) {
  for (int i = 1; i <= 2; ++i) WriteImage(dir_ / (std::to_string(i) + ".png"), Image(i));
  WriteText(dir_ / "groundtruth.csv", "1,room a\n2,room b\n");  // no header
  const Dataset ds = Dataset::Open(dir_);
  EXPECT_EQ(ds.labels(), (std::vector<std::string>{"room a", "room b"}));
  EXPECT_TRUE(ds.poses().empty());
}

TEST_F(DatasetTest, GroundTruthFrameOutOfRangeNamesTheFile) {
  WriteImage(dir_ / "1.png", Image(1));
  WriteText(dir_ / "groundtruth.csv", "frame,place\n7,kitchen\n");
  ExpectErrorNaming([&] { Dataset::Open(dir_); }, "groundtruth.csv");
}

TEST_F(DatasetTest, RevisitOfALaterFrameNamesTheFile) {
  for (int i = 1; i <= 3; ++i) WriteImage(dir_ / (std::to_string(i) + ".png"), Image(i));
  WriteText(dir_ / "revisits.csv", "frame,revisits\n2,3\n");
  ExpectErrorNaming([&] { Dataset::Open(dir_); }, "revisits.csv");
}

TEST_F(DatasetTest, MissingFolderNamesIt) {
  const fs::path missing = dir_ / "nowhere";
  ExpectErrorNaming([&] { Dataset::Open(missing); }, missing.string());
}

TEST_F(DatasetTest, FileInsteadOfFolderNamesIt) {
  WriteText(dir_ / "file.txt", "x");
  ExpectErrorNaming([&] { Dataset::Open(dir_ / "file.txt"); }, "file.txt");
}

TEST_F(DatasetTest, EmptyFolderNamesIt) {
  ExpectErrorNaming([&] { Dataset::Open(dir_); }, dir_.string());
}

TEST_F(DatasetTest, ZeroSizeImageNamesTheFile) {
  WriteImage(dir_ / "1.png", Image(1));
  WriteText(dir_ / "2.png", "");
  ExpectErrorNaming([&] { Dataset::Open(dir_); }, "2.png");
}

TEST_F(DatasetTest, UnreadableImageNamesTheFile) {
  WriteImage(dir_ / "1.jpg", Image(1));
  std::mt19937 rng(7);
  std::string garbage(600, '\0');
  for (char& c : garbage) c = static_cast<char>(rng() & 0xff);
  WriteText(dir_ / "2.jpg", garbage);
  const Dataset ds = Dataset::Open(dir_);  // only the first image is decoded when opening
  EXPECT_NO_THROW(ds.Load(0));
  ExpectErrorNaming([&] { ds.Load(1); }, "2.jpg");
  // As the first frame it fails at once.
  fs::remove(dir_ / "1.jpg");
  ExpectErrorNaming([&] { Dataset::Open(dir_); }, "2.jpg");
}

// Regression (fuzz_dataset_image): a frame that OpenCV would hand to another decoder by its
// content (here GDCM, for the "DICM" inside) is refused by name; GDCM aborted the process.
TEST_F(DatasetTest, FrameThatIsNotAJpegOrPngIsRefusedNotDecoded) {
  std::ifstream in(
      std::string(TSCD_SOURCE_DIR) + "/fuzz/regressions/fuzz_dataset_image/gdcm-assert-dicm",
      std::ios::binary);
  ASSERT_TRUE(in);
  const std::string dicom((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_NE(dicom.find("DICM"), std::string::npos);
  WriteText(dir_ / "1.png", dicom);
  ExpectErrorNaming([&] { Dataset::Open(dir_); }, "1.png");
  WriteImage(dir_ / "0.png", Image(0));
  const Dataset ds = Dataset::Open(dir_);
  ExpectErrorNaming([&] { ds.Load(1); }, "1.png");
}

TEST_F(DatasetTest, ImageOfAnotherSizeNamesTheFile) {
  WriteImage(dir_ / "1.png", Image(1, 32, 24));
  WriteImage(dir_ / "2.png", Image(2, 48, 24));
  const Dataset ds = Dataset::Open(dir_);
  ExpectErrorNaming([&] { ds.Load(1); }, "2.png");
}

TEST_F(DatasetTest, MissingDepthNamesTheFile) {
  for (int i = 1; i <= 2; ++i) WriteImage(dir_ / (std::to_string(i) + ".jpg"), Image(i));
  WriteImage(dir_ / "depth" / "1.png", cv::Mat(24, 32, CV_16UC1, cv::Scalar(1000)));
  ExpectErrorNaming([&] { Dataset::Open(dir_); }, (fs::path("depth") / "2.png").string());
}

TEST_F(DatasetTest, DepthOfAnotherSizeNamesTheFile) {
  WriteImage(dir_ / "1.jpg", Image(1));
  WriteImage(dir_ / "depth" / "1.png", cv::Mat(12, 16, CV_16UC1, cv::Scalar(1000)));
  const Dataset ds = Dataset::Open(dir_);
  ExpectErrorNaming([&] { ds.Load(0); }, (fs::path("depth") / "1.png").string());
}

TEST_F(DatasetTest, EightBitDepthNamesTheFile) {
  WriteImage(dir_ / "1.jpg", Image(1));
  WriteImage(dir_ / "depth" / "1.png", cv::Mat(24, 32, CV_8UC1, cv::Scalar(10)));
  const Dataset ds = Dataset::Open(dir_);
  ExpectErrorNaming([&] { ds.Load(0); }, (fs::path("depth") / "1.png").string());
}

// Issue 18: a 1.1 MB PNG of deflated zeros whose header says 20000x20000 (1.2 GB decoded) as
// the first frame. It is refused from its header, the error names the file and the claimed
// size, and the process's peak resident set grows by about the file, not by the image.
TEST_F(DatasetTest, BombAsFirstFrameIsRefusedByItsHeaderNamingFileAndClaimedSize) {
  testing_support::WriteBytes(dir_ / "1.png", testing_support::ZeroPngBomb(20000, 20000));
  WriteImage(dir_ / "2.png", Image(2));
  const bool can_measure = testing_support::ResetPeakRss();
  const long before_kb = testing_support::RssKb();
  ExpectErrorNaming([&] { Dataset::Open(dir_); }, "1.png");
  ExpectErrorNaming([&] { Dataset::Open(dir_); }, "claims 20000x20000 pixels");
  if (can_measure) {
    const long grew_kb = testing_support::PeakRssKb() - before_kb;
    std::printf("peak RSS grew by %ld kB while refusing the 20000x20000 PNG twice\n", grew_kb);
    EXPECT_LT(grew_kb, 32 * 1024);
  }
}

// A bomb among the frames (the 20512x35225 JPEG) fails its own Load, naming itself and what it
// claims; the frames after it load as before: nothing is blamed on them.
TEST_F(DatasetTest, BombAmongTheFramesFailsItsOwnLoadAndTheNextFrameLoads) {
  WriteImage(dir_ / "1.jpg", Image(1));
  testing_support::WriteBytes(dir_ / "2.jpg", testing_support::ForgedJpegBomb());
  WriteImage(dir_ / "3.jpg", Image(3));
  const Dataset ds = Dataset::Open(dir_);
  EXPECT_NO_THROW(ds.Load(0));
  ExpectErrorNaming([&] { ds.Load(1); }, "2.jpg");
  ExpectErrorNaming([&] { ds.Load(1); }, "claims 20512x35225 pixels");
  EXPECT_NO_THROW(ds.Load(2));
  EXPECT_EQ(ds.Load(2).front().bgr.size(), cv::Size(32, 24));
}

// The limit is the configured one (camera.max_image_pixels), and it applies to depth too.
TEST_F(DatasetTest, TheImageLimitIsConfigurable) {
  WriteImage(dir_ / "1.png", Image(1, 32, 24));
  DatasetOptions options;
  options.max_image_pixels = 32 * 24 - 1;
  ExpectErrorNaming([&] { Dataset::Open(dir_, options); }, "more than the limit of 767");
  options.max_image_pixels = 32 * 24;
  EXPECT_NO_THROW(Dataset::Open(dir_, options));
  options.max_image_pixels = 0;
  EXPECT_THROW(Dataset::Open(dir_, options), std::invalid_argument);
  // A depth bomb is refused by its header too (it must have its frame's size).
  testing_support::WriteBytes(
      dir_ / "depth" / "1.png",
      (fs::create_directories(dir_ / "depth"), testing_support::ForgedPngBomb(20000, 20000)));
  const Dataset ds = Dataset::Open(dir_);
  ExpectErrorNaming([&] { ds.Load(0); }, "20000x20000");
}

}  // namespace
}  // namespace tsc

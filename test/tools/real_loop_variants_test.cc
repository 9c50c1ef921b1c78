// The real loop (../shared/data/rtabmap-loop) as other cameras would have taken it: other
// resolutions, darker or brighter exposure, half the keyframes, sensor noise, a monochrome
// sensor, blur, harder JPEG compression (an MJPEG camera's). The
// defaults are calibrated on simulated worlds and checked on this loop as it is; these
// variants check that the check does not hinge on the loop's own camera (issue 19: "a change
// that only fits the visible loop will show"). Nothing was tuned on them; they are scored with
// config/tscd.ini untouched. Every variant measured is here: those that fail are known failures
// (below), with what fails.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "drivers/dataset/dataset.h"
#include "test/support/default_profile.h"
#include "test/support/known_failure.h"
#include "test/support/temp_dir.h"
#include "tools/eval.h"

namespace tsc {
namespace {
namespace fs = std::filesystem;

struct CameraVariant {
  const char* name;
  int stride = 1;      ///< keep every stride-th frame (1 = all)
  double scale = 1.0;  ///< image size factor
  double gain = 1.0;   ///< out = 255·gain·(in/255)^gamma + noise, clipped
  double gamma = 1.0;
  double noise_sigma = 0.0;  ///< grey levels, gaussian, seeded by the frame number
  bool grey = false;         ///< a monochrome camera (the grey image in all three channels)
  double blur_sigma = 0.0;   ///< gaussian blur in pixels (defocus, motion), before the light
  int jpeg_quality = 95;     ///< the frames' JPEG quality (compression artefacts)
};

std::ostream& operator<<(std::ostream& os, const CameraVariant& v) { return os << v.name; }

// Writes the loop as `v` would have recorded it into `out`, with revisits.csv renumbered: frame
// k of the variant (0-based) is frame k·stride of the loop, and keeps the revisits it still has.
void WriteVariant(const fs::path& loop, const CameraVariant& v, const fs::path& out) {
  fs::create_directories(out);
  const Dataset recorded = Dataset::Open(loop);
  ASSERT_EQ(static_cast<int>(recorded.revisits().size()), recorded.size()) << "revisits.csv";
  std::ofstream csv(out / "revisits.csv");
  csv << "frame,revisits\n";
  for (int f = 0; f < recorded.size(); f += v.stride) {
    cv::Mat img = cv::imread(recorded.image_path(f).string());
    ASSERT_FALSE(img.empty()) << recorded.image_path(f);
    if (v.scale != 1.0) cv::resize(img, img, cv::Size(), v.scale, v.scale, cv::INTER_AREA);
    if (v.grey) {
      cv::cvtColor(img, img, cv::COLOR_BGR2GRAY);
      cv::cvtColor(img, img, cv::COLOR_GRAY2BGR);
    }
    if (v.blur_sigma > 0.0) cv::GaussianBlur(img, img, cv::Size(), v.blur_sigma);
    cv::Mat light;
    img.convertTo(light, CV_32F, 1.0 / 255.0);
    cv::pow(light, v.gamma, light);
    light *= 255.0 * v.gain;
    if (v.noise_sigma > 0.0) {
      cv::Mat noise(light.size(), light.type());
      cv::RNG rng(static_cast<std::uint64_t>(f + 1));  // seeded by the loop's frame number
      rng.fill(noise, cv::RNG::NORMAL, 0.0, v.noise_sigma);
      light += noise;
    }
    light.convertTo(img, CV_8U);     // saturates
    const int k = f / v.stride + 1;  // 1-based, as the loop's names and revisits.csv
    ASSERT_TRUE(cv::imwrite((out / (std::to_string(k) + ".jpg")).string(), img,
                            {cv::IMWRITE_JPEG_QUALITY, v.jpeg_quality}));
    csv << k << ",";
    const char* sep = "";
    for (int e : recorded.revisits()[static_cast<size_t>(f)]) {
      if (e % v.stride != 0) continue;  // not kept
      csv << sep << e / v.stride + 1;
      sep = " ";
    }
    csv << "\n";
  }
}

void Report(const CameraVariant& v, const EvalResult& r) {
  const RecognitionScore& s = r.main.recognition;
  std::printf(
      "%-8s frames %d, learned %d, recognitions %d (%d right, %d should be), frame-level"
      " precision %.2f recall %.2f, at precision 1 %.2f\n",
      v.name, r.frames, r.main.learned_places, s.recognitions, s.correct, s.should_be_recognized,
      r.main.loop_closure.precision, r.main.loop_closure.recall,
      r.loop_closure_recall_at_full_precision);
}

class RealLoopVariants : public ::testing::TestWithParam<CameraVariant> {
 protected:
  static fs::path Loop() { return fs::path(TSCD_DATA_DIR) / "rtabmap-loop"; }
  EvalResult Evaluate(const CameraVariant& v) {
    const fs::path out = temp_.path() / v.name;
    WriteVariant(Loop(), v, out);
    const Dataset dataset = Dataset::Open(out);
    return tsc::Evaluate(dataset, testing_support::DefaultProfile(dataset), EvalOptions{});
  }
  testing_support::TempDir temp_{"tscd_real_loop_variants"};
};

// Every place-level recognition is right and the loop's two revisited places are still found
// (the loop as it is: 2 of 2). The frame-level figure is printed, not asserted: a variant is a
// check of the decision, and the loop's own bar (0.75) is EvalTest's.
TEST_P(RealLoopVariants, EveryRecognitionIsRightAndTheRevisitsAreFound) {
  if (!fs::exists(Loop())) GTEST_SKIP() << Loop() << " is not present";
  const CameraVariant& v = GetParam();
  const EvalResult r = Evaluate(v);
  Report(v, r);
  const RecognitionScore& s = r.main.recognition;
  EXPECT_EQ(s.correct, s.recognitions) << "a wrong place-level recognition";
  EXPECT_GE(s.correct, 1);
  EXPECT_GE(s.recall, 0.5);
}

INSTANTIATE_TEST_SUITE_P(
    OtherCameras, RealLoopVariants,
    ::testing::Values(CameraVariant{"half", 1, 0.5}, CameraVariant{"quarter", 1, 0.25},
                      CameraVariant{"larger", 1, 1.5},
                      CameraVariant{"brighter", 1, 1.0, 1.3},  // over-exposed, highlights clip
                      CameraVariant{"sparser", 2},             // every second keyframe
                      CameraVariant{"noisier", 1, 1.0, 1.0, 1.0, 4.0},  // gaussian, 4 grey levels
                      CameraVariant{"noisiest", 1, 1.0, 1.0, 1.0, 8.0},
                      CameraVariant{.name = "grey", .grey = true},
                      CameraVariant{.name = "blurred", .blur_sigma = 2.0},
                      CameraVariant{.name = "jpeg20", .jpeg_quality = 20},
                      CameraVariant{.name = "jpeg40", .jpeg_quality = 40},
                      CameraVariant{
                          .name = "dimmer_jpeg40", .gain = 0.6, .gamma = 1.1, .jpeg_quality = 40}),
    [](const auto& param_info) { return std::string(param_info.param.name); });

// Known failures, skipped unless TSCD_RUN_KNOWN_FAILURES=1 (docs/results.md, sessions 40 and
// 52). The loop's second stretch of corridor (frames 8-17) is taken for its first (1-5) while
// the memory holds that one place: the ratio term is then 1 (DESIGN §3.3: one child) and only
// the distance and the vote decide, so the decision sits near τ_r 2.9 whatever the camera (as
// recorded it costs 3.40; under-exposed 2.79, over-exposed with a lifted gamma 2.87). Before
// frames were prefiltered on their way to the grid (session 52) it cost 3.14 as recorded and
// was taken for the first place with noise of 4 or 8 grey levels, JPEG quality 20 and glare;
// under-exposed it was kept apart at 2.94. On the simulated worlds such a decision never comes
// near τ_r (a new place against a one-place memory costs 8-19 on the 21 calibration worlds).
class RealLoopKnownFailures : public RealLoopVariants {};

TEST_P(RealLoopKnownFailures, TheFirstTwoPlacesStayApart) {
  if (!testing_support::KnownFailuresRequested()) {
    GTEST_SKIP() << "KNOWN FAILURE (issue 19), set TSCD_RUN_KNOWN_FAILURES=1 to run: the loop's "
                    "second place is taken for its first while the memory holds one place "
                    "(ratio term 1 by DESIGN §3.3)";
  }
  if (!fs::exists(Loop())) GTEST_SKIP() << Loop() << " is not present";
  const EvalResult r = Evaluate(GetParam());
  Report(GetParam(), r);
  EXPECT_EQ(r.main.recognition.correct, r.main.recognition.recognitions);
}

INSTANTIATE_TEST_SUITE_P(OtherCameras, RealLoopKnownFailures,
                         // Under-exposed with gamma 1.3; over-exposed with gamma 0.8.
                         ::testing::Values(CameraVariant{"dim", 1, 1.0, 0.45, 1.3},
                                           CameraVariant{"glaring", 1, 1.0, 1.3, 0.8}),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

}  // namespace
}  // namespace tsc

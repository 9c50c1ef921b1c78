// How a forward camera's thresholds follow its lens (drivers/dataset/lens_response.h): the
// calibrated 58° keeps the configured τ_κ and distance unit; narrower lenses scale both down
// by the response measured at 45° and 50°, wider ones the unit up by that at 75° and 90°,
// continuously between them; a pan sweep keeps its preset; lenses outside 45°-100° are
// cautioned. What the scaling does to recognition is
// SimBarsTest.NarrowerLensIsServedByThresholdsThatFollowIt and
// SimBarsTest.WiderLensRecognisesMoreWithTheUnitThatFollowsIt.

#include "drivers/dataset/lens_response.h"

#include <gtest/gtest.h>

#include <functional>
#include <stdexcept>

#include "core/bubble/camera.h"
#include "core/pipeline/pipeline.h"

namespace tsc {
namespace {

// Both responses rise at every half degree from `from` to `to`, from above `floor`; `also`
// checks each lens's response further.
void ExpectBothRise(double from, double to, double floor,
                    const std::function<void(double, const LensResponse&)>& also) {
  double previous_chi2 = floor, previous_distance = floor;
  for (double hfov = from; hfov <= to; hfov += 0.5) {
    const LensResponse r = LensResponseAt(hfov);
    EXPECT_GT(r.chi2, previous_chi2) << hfov;
    EXPECT_GT(r.squared_distance, previous_distance) << hfov;
    previous_chi2 = r.chi2;
    previous_distance = r.squared_distance;
    also(hfov, r);
  }
}

TEST(LensResponseTest, TheCalibratedLensKeepsTheConfiguredThresholds) {
  const LensResponse r = LensResponseAt(58.0);
  EXPECT_EQ(r.chi2, 1.0);
  EXPECT_EQ(r.squared_distance, 1.0);
  EXPECT_EQ(ChangeResponse(CameraLens()), 1.0);
  PipelineOptions options;
  AdaptToLens(options, CameraLens(58.0, 1));
  EXPECT_EQ(options.reliability.tau_kappa, PipelineOptions{}.reliability.tau_kappa);
  EXPECT_EQ(options.memory.distance_unit, PipelineOptions{}.memory.distance_unit);
  EXPECT_FALSE(LensNote(options, CameraLens(58.0, 1)));
}

TEST(LensResponseTest, WiderLensesScaleTheUnitUpAndKeepTauKappa) {
  EXPECT_NEAR(LensResponseAt(75.0).chi2, 1.123, 1e-12);
  EXPECT_NEAR(LensResponseAt(75.0).squared_distance, 1.223, 1e-12);
  EXPECT_NEAR(LensResponseAt(90.0).chi2, 1.306, 1e-12);
  EXPECT_NEAR(LensResponseAt(90.0).squared_distance, 1.405, 1e-12);
  ExpectBothRise(58.5, 90.0, 1.0, [](double hfov, const LensResponse&) {
    PipelineOptions options;
    AdaptToLens(options, CameraLens(hfov, 1));
    EXPECT_EQ(options.reliability.tau_kappa, PipelineOptions{}.reliability.tau_kappa) << hfov;
  });
  // Wider than measured: held at 90°'s.
  EXPECT_EQ(LensResponseAt(110.0).squared_distance, LensResponseAt(90.0).squared_distance);
  PipelineOptions options;
  AdaptToLens(options, CameraLens(90.0, 1));
  EXPECT_EQ(options.reliability.tau_kappa, PipelineOptions{}.reliability.tau_kappa);
  EXPECT_NEAR(options.memory.distance_unit, 1.405 * PipelineOptions{}.memory.distance_unit, 1e-18);
  const std::optional<std::string> note = LensNote(options, CameraLens(90.0, 1));
  ASSERT_TRUE(note);
  EXPECT_NE(note->find("a 90° lens: detection.tau_kappa 0.02 (as configured) and"),
            std::string::npos)
      << *note;
}

// A unit configured near the top of its range stays in it at a wide lens (it left the range,
// and the memory refused it when the pipeline started).
TEST(LensResponseTest, TheScaledUnitStaysInTheKeysRange) {
  PipelineOptions options;
  options.memory.distance_unit = PlaceMemoryOptions::kDistanceUnitRange.max;
  AdaptToLens(options, CameraLens(90.0, 1));
  EXPECT_EQ(options.memory.distance_unit, PlaceMemoryOptions::kDistanceUnitRange.max);
  EXPECT_NO_THROW(options.Validate());
}

TEST(LensResponseTest, NarrowerLensesScaleBothDownContinuously) {
  EXPECT_NEAR(LensResponseAt(45.0).chi2, 0.616, 1e-12);
  EXPECT_NEAR(LensResponseAt(45.0).squared_distance, 0.554, 1e-12);
  EXPECT_NEAR(LensResponseAt(50.0).chi2, 0.799, 1e-12);
  EXPECT_NEAR(LensResponseAt(50.0).squared_distance, 0.742, 1e-12);
  // Monotone from 45° to 58°, and continuous at the measured lenses.
  ExpectBothRise(45.0, 58.0, 0.0, [](double, const LensResponse& r) { EXPECT_LE(r.chi2, 1.0); });
  EXPECT_NEAR(LensResponseAt(57.999).chi2, 1.0, 1e-4);
  EXPECT_NEAR(LensResponseAt(50.001).squared_distance, 0.742, 1e-4);
  // Narrower than measured: held at 45°'s.
  EXPECT_EQ(LensResponseAt(30.0).chi2, LensResponseAt(45.0).chi2);
  EXPECT_EQ(LensResponseAt(30.0).squared_distance, LensResponseAt(45.0).squared_distance);

  PipelineOptions options;
  AdaptToLens(options, CameraLens(45.0, 1));
  EXPECT_NEAR(options.reliability.tau_kappa, 0.616 * PipelineOptions{}.reliability.tau_kappa,
              1e-12);
  EXPECT_NEAR(options.memory.distance_unit, 0.554 * PipelineOptions{}.memory.distance_unit, 1e-18);
  const std::optional<std::string> note = LensNote(options, CameraLens(45.0, 1));
  ASSERT_TRUE(note);
  EXPECT_NE(note->find("45° lens"), std::string::npos) << *note;
  EXPECT_NE(note->find("tau_kappa 0.0123 (scaled)"), std::string::npos) << *note;
}

TEST(LensResponseTest, APanSweepKeepsItsPreset) {
  PipelineOptions options;
  options.memory.distance_unit = 3e-5;
  const CameraLens sweep(45.0, 6);
  EXPECT_FALSE(sweep.forward());
  AdaptToLens(options, sweep);
  EXPECT_EQ(options.reliability.tau_kappa, PipelineOptions{}.reliability.tau_kappa);
  EXPECT_EQ(options.memory.distance_unit, 3e-5);
  EXPECT_FALSE(LensNote(options, sweep));
  EXPECT_FALSE(LensCaution(CameraLens(30.0, 6)));
  EXPECT_EQ(ChangeResponse(sweep), 1.0);
}

TEST(LensResponseTest, LensesOutsideTheMeasuredOnesAreCautioned) {
  EXPECT_FALSE(LensCaution(CameraLens(45.0, 1)));
  EXPECT_FALSE(LensCaution(CameraLens(60.0, 1)));
  EXPECT_FALSE(LensCaution(CameraLens(100.0, 1)));
  const std::optional<std::string> narrow = LensCaution(CameraLens(40.0, 1));
  ASSERT_TRUE(narrow);
  EXPECT_NE(narrow->find("45° to 100°"), std::string::npos) << *narrow;
  EXPECT_TRUE(LensCaution(CameraLens(120.0, 1)));
}

TEST(LensResponseTest, AFieldOfViewOutsideZeroTo180IsRefused) {
  EXPECT_THROW(LensResponseAt(0.0), std::invalid_argument);
  EXPECT_THROW(LensResponseAt(180.0), std::invalid_argument);
  EXPECT_THROW(LensResponseAt(-5.0), std::invalid_argument);
  EXPECT_THROW(CameraLens(0.0, 1), std::invalid_argument);
  EXPECT_THROW(CameraLens(180.0, 1), std::invalid_argument);
  EXPECT_THROW(CameraLens(60.0, 0), std::invalid_argument);
}

TEST(LensResponseTest, TheFieldOfViewOfACameraIsTheOneItWasMadeWith) {
  EXPECT_EQ(CameraLens::Of(CameraIntrinsics::FromHorizontalFov(160, 120, 45.0), 1).hfov_deg(),
            45.0);
  EXPECT_EQ(CameraLens::Of(CameraIntrinsics::FromHorizontalFov(640, 480, 58.0), 1).hfov_deg(),
            58.0);
  // fx = w / 2: 90°.
  const CameraLens lens = CameraLens::Of(CameraIntrinsics(320, 240, 160.0, 160.0, 160.0, 120.0), 6);
  EXPECT_EQ(lens.hfov_deg(), 90.0);
  EXPECT_EQ(lens.views_per_base_point(), 6);
}

}  // namespace
}  // namespace tsc

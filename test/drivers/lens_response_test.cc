// How a forward camera's thresholds follow its lens (drivers/dataset/lens_response.h): the
// calibrated 58° keeps the configured τ_κ and distance unit; narrower lenses scale both down
// by the response measured at 45° and 50°, wider ones the unit up by that at 75° and 90°,
// continuously between them; a pan sweep keeps its preset; lenses outside 45°-100° are
// cautioned. What the scaling does to
// recognition is SimBarsTest.NarrowerLensIsServedByThresholdsThatFollowIt.

#include "drivers/dataset/lens_response.h"

#include <gtest/gtest.h>

#include <stdexcept>

#include "core/bubble/camera.h"
#include "core/pipeline/pipeline.h"

namespace tsc {
namespace {

TEST(LensResponseTest, TheCalibratedLensKeepsTheConfiguredThresholds) {
  const LensResponse r = LensResponseAt(58.0);
  EXPECT_EQ(r.kappa, 1.0);
  EXPECT_EQ(r.unit, 1.0);
  PipelineOptions options;
  AdaptToLens(options, 58.0, 1);
  EXPECT_EQ(options.reliability.tau_kappa, PipelineOptions{}.reliability.tau_kappa);
  EXPECT_EQ(options.memory.distance_unit, PipelineOptions{}.memory.distance_unit);
  EXPECT_FALSE(LensNote(options, 58.0, 1));
}

TEST(LensResponseTest, WiderLensesScaleTheUnitUpAndKeepTauKappa) {
  EXPECT_NEAR(LensResponseAt(75.0).unit, 1.223, 1e-12);
  EXPECT_NEAR(LensResponseAt(90.0).unit, 1.405, 1e-12);
  double previous_unit = 1.0;
  for (double hfov = 58.5; hfov <= 90.0; hfov += 0.5) {
    const LensResponse r = LensResponseAt(hfov);
    EXPECT_EQ(r.kappa, 1.0) << hfov;
    EXPECT_GT(r.unit, previous_unit) << hfov;
    previous_unit = r.unit;
  }
  // Wider than measured: held at 90°'s.
  EXPECT_EQ(LensResponseAt(110.0).unit, LensResponseAt(90.0).unit);
  PipelineOptions options;
  AdaptToLens(options, 90.0, 1);
  EXPECT_EQ(options.reliability.tau_kappa, PipelineOptions{}.reliability.tau_kappa);
  EXPECT_NEAR(options.memory.distance_unit, 1.405 * PipelineOptions{}.memory.distance_unit, 1e-18);
  const std::optional<std::string> note = LensNote(options, 90.0, 1);
  ASSERT_TRUE(note);
  EXPECT_NE(note->find("a 90° lens: detection.tau_kappa 0.02 and"), std::string::npos) << *note;
}

TEST(LensResponseTest, NarrowerLensesScaleBothDownContinuously) {
  EXPECT_NEAR(LensResponseAt(45.0).kappa, 0.616, 1e-12);
  EXPECT_NEAR(LensResponseAt(45.0).unit, 0.554, 1e-12);
  EXPECT_NEAR(LensResponseAt(50.0).kappa, 0.799, 1e-12);
  EXPECT_NEAR(LensResponseAt(50.0).unit, 0.742, 1e-12);
  // Monotone from 45° to 58°, and continuous at the measured lenses.
  double previous_kappa = 0.0, previous_unit = 0.0;
  for (double hfov = 45.0; hfov <= 58.0; hfov += 0.5) {
    const LensResponse r = LensResponseAt(hfov);
    EXPECT_GT(r.kappa, previous_kappa) << hfov;
    EXPECT_GT(r.unit, previous_unit) << hfov;
    EXPECT_LE(r.kappa, 1.0);
    previous_kappa = r.kappa;
    previous_unit = r.unit;
  }
  EXPECT_NEAR(LensResponseAt(57.999).kappa, 1.0, 1e-4);
  EXPECT_NEAR(LensResponseAt(50.001).unit, 0.742, 1e-4);
  // Narrower than measured: held at 45°'s.
  EXPECT_EQ(LensResponseAt(30.0).kappa, LensResponseAt(45.0).kappa);
  EXPECT_EQ(LensResponseAt(30.0).unit, LensResponseAt(45.0).unit);

  PipelineOptions options;
  AdaptToLens(options, 45.0, 1);
  EXPECT_NEAR(options.reliability.tau_kappa, 0.616 * PipelineOptions{}.reliability.tau_kappa,
              1e-12);
  EXPECT_NEAR(options.memory.distance_unit, 0.554 * PipelineOptions{}.memory.distance_unit, 1e-18);
  const std::optional<std::string> note = LensNote(options, 45.0, 1);
  ASSERT_TRUE(note);
  EXPECT_NE(note->find("45° lens"), std::string::npos) << *note;
  EXPECT_NE(note->find("tau_kappa 0.0123"), std::string::npos) << *note;
}

TEST(LensResponseTest, APanSweepKeepsItsPreset) {
  PipelineOptions options;
  options.memory.distance_unit = 3e-5;
  AdaptToLens(options, 45.0, 6);
  EXPECT_EQ(options.reliability.tau_kappa, PipelineOptions{}.reliability.tau_kappa);
  EXPECT_EQ(options.memory.distance_unit, 3e-5);
  EXPECT_FALSE(LensNote(options, 45.0, 6));
  EXPECT_FALSE(LensCaution(30.0, 6));
}

TEST(LensResponseTest, LensesOutsideTheMeasuredOnesAreCautioned) {
  EXPECT_FALSE(LensCaution(45.0, 1));
  EXPECT_FALSE(LensCaution(60.0, 1));
  EXPECT_FALSE(LensCaution(100.0, 1));
  const std::optional<std::string> narrow = LensCaution(40.0, 1);
  ASSERT_TRUE(narrow);
  EXPECT_NE(narrow->find("45° to 100°"), std::string::npos) << *narrow;
  EXPECT_TRUE(LensCaution(120.0, 1));
}

TEST(LensResponseTest, AFieldOfViewOutsideZeroTo180IsRefused) {
  EXPECT_THROW(LensResponseAt(0.0), std::invalid_argument);
  EXPECT_THROW(LensResponseAt(180.0), std::invalid_argument);
  EXPECT_THROW(LensResponseAt(-5.0), std::invalid_argument);
}

TEST(LensResponseTest, TheFieldOfViewOfACameraIsTheOneItWasMadeWith) {
  EXPECT_EQ(HorizontalFovDeg(CameraIntrinsics::FromHorizontalFov(160, 120, 45.0)), 45.0);
  EXPECT_EQ(HorizontalFovDeg(CameraIntrinsics::FromHorizontalFov(640, 480, 58.0)), 58.0);
  // fx = w / 2: 90°.
  EXPECT_EQ(HorizontalFovDeg(CameraIntrinsics(320, 240, 160.0, 160.0, 160.0, 120.0)), 90.0);
}

}  // namespace
}  // namespace tsc

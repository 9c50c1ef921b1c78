#include "core/memory/view_basis.h"

#include <gtest/gtest.h>

#include <Eigen/QR>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/memory/builtin_view_basis.h"
#include "core/memory/place_memory.h"
#include "core/merge/merge.h"
#include "core/pipeline/pipeline.h"
#include "test/support/synthetic_places.h"

namespace tsc {
namespace {

using testing_support::SyntheticPlaces;

// A k x dim matrix of orthonormal rows drawn from `seed` (a random rotation when k = dim).
Eigen::MatrixXf RandomAxes(int k, int dim, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::MatrixXd g(dim, dim);
  for (Eigen::Index i = 0; i < g.size(); ++i) g.data()[i] = n(rng);
  const Eigen::MatrixXd q = Eigen::HouseholderQR<Eigen::MatrixXd>(g).householderQ();
  return q.leftCols(k).transpose().cast<float>();
}

TEST(ViewBasis, PrincipalAxesFindThePlaneTheDataLieIn) {
  // Points in the plane of two fixed directions of 20 dimensions, plus noise 1000x smaller.
  std::mt19937 rng(5);
  std::normal_distribution<float> n(0.0f, 1.0f);
  const Eigen::MatrixXf plane = RandomAxes(2, 20, 9);
  Eigen::MatrixXf x(20, 300);
  for (Eigen::Index j = 0; j < x.cols(); ++j) {
    x.col(j) = plane.transpose() * Eigen::Vector2f(3 * n(rng), n(rng));
    for (Eigen::Index i = 0; i < x.rows(); ++i) x(i, j) += 1e-3f * n(rng) + 0.5f;  // off centre
  }
  double retained = 0;
  const Eigen::MatrixXf axes = PrincipalAxes(x, 2, &retained);
  EXPECT_GT(retained, 0.9999);
  // Each axis lies in the plane: its projection onto the plane keeps its length.
  for (int i = 0; i < 2; ++i) EXPECT_NEAR((plane * axes.row(i).transpose()).norm(), 1.0, 1e-3);
  // The first axis is the long one, and every axis is signed by its largest component.
  EXPECT_GT((axes.row(0) * (x.colwise() - x.rowwise().mean())).squaredNorm(),
            4 * (axes.row(1) * (x.colwise() - x.rowwise().mean())).squaredNorm());
  for (int i = 0; i < 2; ++i) {
    Eigen::Index largest = 0;
    axes.row(i).cwiseAbs().maxCoeff(&largest);
    EXPECT_GT(axes(i, largest), 0.0f);
  }
  EXPECT_NO_THROW(ViewBasis(axes, "fitted"));
  EXPECT_THROW(PrincipalAxes(x, 21), std::invalid_argument);
  EXPECT_THROW(PrincipalAxes(x.leftCols(1), 1), std::invalid_argument);
}

TEST(ViewBasis, BytesRoundTripAndForgeriesAreRefused) {
  const Eigen::MatrixXf axes = RandomAxes(3, 10, 1);
  const std::vector<uint8_t> bytes = ViewBasisBytes(axes);
  EXPECT_EQ(bytes.size(), 16u + 4u * 30u);
  const ViewBasis basis = ParseViewBasis(bytes, "file");
  EXPECT_EQ(basis.axes(), axes);
  EXPECT_EQ(basis.dimension(), 3);
  EXPECT_EQ(basis.input_dimension(), 10);
  EXPECT_EQ(basis.name(), "file");
  EXPECT_EQ(basis.id(), ViewBasis(axes, "other name").id());
  EXPECT_NE(basis.id(), ViewBasis(RandomAxes(3, 10, 2), "file").id());

  std::vector<uint8_t> bad = bytes;
  bad[0] = 'X';
  EXPECT_THROW(ParseViewBasis(bad, "f"), std::invalid_argument);  // magic
  bad = bytes;
  bad.pop_back();
  EXPECT_THROW(ParseViewBasis(bad, "f"), std::invalid_argument);  // truncated
  bad = bytes;
  bad[8] = 0xff, bad[9] = 0xff, bad[10] = 0xff, bad[11] = 0x7f;  // claims 2^31 axes
  EXPECT_THROW(ParseViewBasis(bad, "f"), std::invalid_argument);
  // Axes that are not orthonormal would shrink or skew every distance.
  EXPECT_THROW(ViewBasis(2 * axes, "scaled"), std::invalid_argument);
  Eigen::MatrixXf nan = axes;
  nan(0, 0) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(ViewBasis(nan, "nan"), std::invalid_argument);
  EXPECT_THROW(basis.Coordinates(Eigen::MatrixXf::Ones(9, 2)), std::invalid_argument);
}

// A place's centre is the coordinates of its mean: Learn takes one mean, Restore a whole
// memory's at once, and the two must agree to the bit or a restored memory would estimate
// and recognise differently from the one that was saved. Both instruction sets agree up to
// rounding.
TEST(ViewBasis, AColumnGetsTheSameCoordinatesAloneOrWithOthers) {
  std::mt19937 rng(11);
  std::normal_distribution<float> n(0.0f, 1.0f);
  const Eigen::MatrixXf axes = RandomAxes(24, 70, 4);
  Eigen::MatrixXf x(70, 13);
  for (Eigen::Index i = 0; i < x.size(); ++i) x.data()[i] = n(rng);
  const ViewBasis fastest(axes, "fastest"), portable(axes, "portable", Simd::kPortable);
  for (const ViewBasis* basis : {&fastest, &portable}) {
    SCOPED_TRACE(basis->name());
    const Eigen::MatrixXf together = basis->Coordinates(x);
    for (Eigen::Index j = 0; j < x.cols(); ++j) {
      const Eigen::MatrixXf alone = basis->Coordinates(x.col(j));
      for (Eigen::Index i = 0; i < together.rows(); ++i) EXPECT_EQ(together(i, j), alone(i, 0));
    }
    EXPECT_TRUE(together.isApprox(axes * x, 1e-5f));
  }
}

// coordinate_error() bounds what Coordinates is off by (against the product in double), and
// DistanceBelow turns coordinate distances into distances no larger than the descriptors',
// on either kernel; inside the basis it gives up little.
TEST(ViewBasis, DistanceBelowIsBelowTheDescriptorDistance) {
  std::mt19937 rng(12);
  std::normal_distribution<float> n(0.0f, 1.0f);
  const Eigen::MatrixXf axes = RandomAxes(16, 300, 5);
  const ViewBasis fastest(axes, "fastest"), portable(axes, "portable", Simd::kPortable);
  for (const ViewBasis* basis : {&fastest, &portable}) {
    SCOPED_TRACE(basis->name());
    EXPECT_GT(basis->coordinate_error(), 0.0);
    EXPECT_LT(basis->coordinate_error(), 1e-3);
    for (int trial = 0; trial < 200; ++trial) {
      // Half the pairs inside the basis (then the bound is nearly the distance), half not;
      // an offset common to both makes the norms large against the distance.
      Eigen::VectorXf x(300), y(300), offset(300);
      for (Eigen::Index i = 0; i < 300; ++i) {
        x(i) = n(rng);
        y(i) = n(rng);
        offset(i) = 30.0f * n(rng);
      }
      if (trial % 2 == 0) {
        x = axes.transpose() * (axes * x);
        y = axes.transpose() * (axes * y);
        offset = axes.transpose() * (axes * offset);
      }
      x += offset;
      y += offset;
      const Eigen::VectorXf cx = basis->Coordinates(x), cy = basis->Coordinates(y);
      for (const auto& [v, c] : {std::pair{&x, &cx}, std::pair{&y, &cy}}) {
        const Eigen::VectorXd exact = axes.cast<double>() * v->cast<double>();
        ASSERT_LE((c->cast<double>() - exact).norm(),
                  basis->coordinate_error() * v->cast<double>().norm());
      }
      const double apart = (cx - cy).cast<double>().norm(), d = (x - y).cast<double>().norm();
      const double below = basis->DistanceBelow(
          apart, basis->coordinate_error() * (x.cast<double>().norm() + y.cast<double>().norm()));
      ASSERT_LE(below, d) << "trial " << trial;
      ASSERT_LE(below, static_cast<double>((x - y).norm())) << "trial " << trial;
      if (trial % 2 == 0) {
        EXPECT_GT(below, 0.99 * d) << "trial " << trial;
      }
    }
  }
}

// The basis tscd ships (core/memory/data/view_basis.bin). Its id is what a team compares: a
// new basis file changes it, and robots of the old and the new basis stop merging each other.
TEST(ViewBasis, TheBuiltinBasisTakesTheDefaultDescriptors) {
  const std::shared_ptr<const ViewBasis> basis = BuiltinViewBasis();
  ASSERT_NE(basis, nullptr);
  EXPECT_EQ(basis->name(), "builtin");
  EXPECT_EQ(basis->dimension(), 128);
  EXPECT_EQ(basis->input_dimension(), 1200);
  EXPECT_EQ(basis->id(), 0xa126e3a0e17dfd97ull);
  EXPECT_EQ(BuiltinViewBasis().get(), basis.get());  // parsed once
  EXPECT_EQ(PipelineOptions{}.memory.view_basis.get(), basis.get());
}

// Recognition and learning measure only in the view space: in a rotation of the descriptor
// space (every distance kept) a memory recognises and learns exactly as without a basis. A
// term measured on a view in one space and a mean or vote point in the other would not.
TEST(ViewBasis, ARotationChangesNoRecognition) {
  constexpr int kDim = 60;
  const SyntheticPlaces world(3, kDim, 12, 0.04f);
  PlaceMemoryOptions rotated;
  rotated.view_basis = std::make_shared<const ViewBasis>(RandomAxes(kDim, kDim, 4), "rotation");
  // Every place measured: the view index's random projection is not rotation invariant, so
  // its estimates (the ratio's N² for places left out of a shortlist) would differ.
  rotated.shortlist = 0;
  PlaceMemoryOptions plain = rotated;
  plain.view_basis = nullptr;
  PlaceMemory a(1, plain), b(1, rotated);
  int recognised = 0;
  for (int visit = 0; visit < 3; ++visit) {
    for (int p = 0; p < 12; ++p) {
      const DetectedPlace d = world.Visit(p, static_cast<uint32_t>(visit), 8);
      const Recognition ra = a.Recognize(d), rb = b.Recognize(d);
      ASSERT_EQ(ra.place, rb.place) << "place " << p << " visit " << visit;
      // Views in 8 bits on each space's own axes round differently: up to 5 % of a cost
      // here, whose views lie 4 % apart (on the calibration worlds a median 0.27 %; a term
      // measured in the wrong space is off by its whole size).
      EXPECT_NEAR(ra.cost, rb.cost, 0.1 * std::max(1.0, std::abs(ra.cost)));
      if (ra.place) {
        ++recognised;
        a.Update(*ra.place, d);
        b.Update(*rb.place, d);
      } else {
        a.Learn(d);
        b.Learn(d);
      }
    }
  }
  EXPECT_GT(recognised, 12);  // revisits were recognised, so the comparison meant something
  EXPECT_EQ(a.places().size(), b.places().size());
  EXPECT_EQ(b.places().front().samples.rows(), kDim);
}

TEST(ViewBasis, AMemoryKeptBeforeTheBasisIsTakenIntoItOnRestore) {
  constexpr int kDim = 30;
  const SyntheticPlaces world(8, kDim, 5, 0.04f);
  const PlaceMemory old = testing_support::SyntheticMemory(1, world, 0, 5, 6);
  PlaceMemoryOptions options;
  options.view_basis = std::make_shared<const ViewBasis>(RandomAxes(8, kDim, 2), "eight");
  const PlaceMemory restored =
      PlaceMemory::Restore(1, options, old.places(), old.slink(), old.next_local_id(), {});
  ASSERT_EQ(restored.places().size(), 5u);
  for (size_t i = 0; i < 5; ++i) {
    const Eigen::MatrixXf want = options.view_basis->Coordinates(old.places()[i].samples.Decoded());
    // Kept in 8 bits a coordinate, a power of two an axis: 2⁻⁷ of the axis' largest at most.
    EXPECT_TRUE(restored.places()[i].samples.Decoded().isApprox(want, 1e-2f));
    EXPECT_TRUE(restored.ViewCentre(static_cast<int>(i))
                    .isApprox(options.view_basis->Coordinates(old.places()[i].mean)));
  }
  // Views of another dimension than the basis gives cannot be taken in: a clear refusal.
  std::vector<LearnedPlace> odd = restored.places();
  odd[2].samples = CompactViews(Eigen::MatrixXf::Ones(5, 3));
  try {
    PlaceMemory::Restore(1, options, odd, old.slink(), old.next_local_id(), {});
    FAIL() << "restored views of dimension 5 into a basis of 8";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("memory.view_basis = eight"), std::string::npos)
        << e.what();
  }
}

TEST(ViewBasis, MemoriesOfDifferentBasesAreNotMerged) {
  constexpr int kDim = 30;
  const SyntheticPlaces world(8, kDim, 5, 0.04f);
  PlaceMemoryOptions options;
  options.view_basis = std::make_shared<const ViewBasis>(RandomAxes(8, kDim, 2), "one");
  const PlaceMemory a = testing_support::SyntheticMemory(1, world, 0, 5, 6);
  const PlaceMemory b = testing_support::SyntheticMemory(2, world, 0, 5, 6);
  const PlaceMemory a1 = PlaceMemory::Restore(1, options, a.places(), a.slink(), 6, {});
  options.view_basis = std::make_shared<const ViewBasis>(RandomAxes(8, kDim, 3), "two");
  const PlaceMemory b2 = PlaceMemory::Restore(2, options, b.places(), b.slink(), 6, {});
  EXPECT_THROW(MergeMemories(a1, b2), std::invalid_argument);
  EXPECT_THROW(MergeMemories(a1, b), std::invalid_argument);  // and none against one
  EXPECT_NO_THROW(MergeMemories(a, b));
}

TEST(ViewBasis, APipelineRefusesABasisOfOtherDescriptors) {
  PipelineOptions options;
  options.features = FeatureSet::Parse("L2+I");  // not the features the builtin basis takes
  const CameraIntrinsics camera = CameraIntrinsics::FromHorizontalFov(160, 120, 54.0);
  try {
    Pipeline(camera, options, PlaceMemory(options.robot, options.memory), TopologicalMap{});
    FAIL() << "a 1200-dimensional basis was given other descriptors";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("memory.view_basis = builtin"), std::string::npos)
        << e.what();
  }
  options.memory.view_basis = nullptr;
  EXPECT_NO_THROW(
      Pipeline(camera, options, PlaceMemory(options.robot, options.memory), TopologicalMap{}));
}

}  // namespace
}  // namespace tsc

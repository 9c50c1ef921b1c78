// Member views in 8 bits a coordinate with a power of two per axis
// (core/memory/compact_views.h): every coordinate within 2⁻⁸ of its axis' largest and no
// coarser than the 16-bit grid, decoding the same on every instruction set, and views that
// were decoded once encode to the same bits (they travel through the wire, the store and
// merges in their 16-bit form).

#include "core/memory/compact_views.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <random>
#include <stdexcept>
#include <vector>

#include "core/memory/simd.h"

namespace tsc {
namespace {

constexpr uint32_t kSeed = 1623;

Eigen::MatrixXf RandomViews(std::mt19937& rng, Eigen::Index rows, Eigen::Index cols, float scale) {
  std::normal_distribution<float> n(0.0f, scale);
  Eigen::MatrixXf m(rows, cols);
  for (Eigen::Index k = 0; k < m.size(); ++k) m.data()[k] = n(rng);
  return m;
}

TEST(CompactViews, KeepEveryCoordinateWithinTwoToTheMinusEightOfItsAxis) {
  std::cout << "seed " << kSeed << "\n";
  std::mt19937 rng(kSeed);
  for (float scale : {1e-9f, 1e-4f, 0.01f, 1.0f, 3e4f, 1e8f}) {
    Eigen::MatrixXf views = RandomViews(rng, 128, 32, scale);
    // Axes of falling magnitude, as a principal basis' are: the last ones on the 16-bit grid.
    for (Eigen::Index r = 0; r < views.rows(); ++r)
      views.row(r) *= std::ldexp(1.0f, -static_cast<int>(r / 8));
    const CompactViews compact(views);
    ASSERT_EQ(compact.rows(), 128);
    ASSERT_EQ(compact.cols(), 32);
    EXPECT_EQ(compact.bytes(), 128u * 32u + 128u);
    const Eigen::MatrixXf back = compact.Decoded();
    const float most = views.cwiseAbs().maxCoeff();
    for (Eigen::Index r = 0; r < views.rows(); ++r) {
      const float row_most = views.row(r).cwiseAbs().maxCoeff();
      const float error = (back.row(r) - views.row(r)).cwiseAbs().maxCoeff();
      // Half a step of the row's grid: its largest code is at least 64, or the row is on the
      // 16-bit grid (step 2⁻¹⁴ of the largest at most).
      ASSERT_LE(error, std::max(row_most / 127.0f, most * 0x1p-15f)) << scale << " row " << r;
    }
    // The small axes keep the 16-bit grid's precision: the last row is 2⁻¹⁵ of the first.
    EXPECT_LE((back.row(127) - views.row(127)).cwiseAbs().maxCoeff(), most * 0x1p-15f);
    EXPECT_GT((back.row(0) - views.row(0)).cwiseAbs().maxCoeff(), most * 0x1p-12f) << scale;
  }
}

// Decoded views encode to the same bits, however often they travel; the largest coordinate
// rounding up to the next power of two included.
TEST(CompactViews, DecodedViewsEncodeToTheSameBits) {
  std::mt19937 rng(kSeed);
  int rounded_up = 0;
  for (int k = 0; k < 300; ++k) {
    const int e = k % 40 - 20;
    Eigen::MatrixXf views = RandomViews(rng, 16, 5, std::ldexp(0.1f, e));
    if (k % 3 == 0) {
      views(3, 2) = std::ldexp(0.99999f, e);  // rounds up to 2^e on the grid
      ++rounded_up;
    }
    const CompactViews once(views);
    const CompactViews twice(once.Decoded());
    ASSERT_EQ(twice, once) << k;
    if (k % 3 == 0) {
      ASSERT_EQ(once.Decoded()(3, 2), std::ldexp(1.0f, e)) << k;
    }
  }
  EXPECT_EQ(rounded_up, 100);
}

// The AVX2 decoding gives the portable one's floats; Col gives the columns of Decoded.
TEST(CompactViews, DecodingIsTheSameOnEveryInstructionSet) {
  std::mt19937 rng(kSeed);
  const CompactViews compact(RandomViews(rng, 37, 7, 0.003f));  // a tail past 8 lanes
  const Eigen::MatrixXf all = compact.Decoded();
  for (Eigen::Index j = 0; j < compact.cols(); ++j) {
    const Eigen::VectorXf col = compact.Col(j);
    for (Eigen::Index r = 0; r < compact.rows(); ++r) {
      ASSERT_EQ(std::bit_cast<uint32_t>(col[r]), std::bit_cast<uint32_t>(all(r, j)));
    }
  }
  // Decoded (on AVX2 where the CPU has it) is the 16-bit form times the shift's power of two.
  const std::vector<int16_t> wide = compact.Wide();
  const float scale = std::ldexp(1.0f, -compact.shift());
  for (Eigen::Index k = 0; k < compact.size(); ++k) {
    const float want = static_cast<float>(wide[static_cast<size_t>(k)]) * scale;
    ASSERT_EQ(std::bit_cast<uint32_t>(all.data()[k]), std::bit_cast<uint32_t>(want)) << k;
  }
  if (FastestSimd() != Simd::kAvx2Fma) GTEST_SKIP() << "no AVX2 on this CPU";
  std::vector<int8_t> codes(20);
  std::vector<uint8_t> drop(10);
  for (int k = 0; k < 20; ++k) codes[static_cast<size_t>(k)] = static_cast<int8_t>(13 * k - 127);
  for (int k = 0; k < 10; ++k) drop[static_cast<size_t>(k)] = static_cast<uint8_t>(k % 9);
  std::vector<float> fast(20);
  avx2::ScaleInt8Rows(codes.data(), drop.data(), 10, 2, 30, fast.data());
  for (int k = 0; k < 20; ++k) {
    const float want = static_cast<float>(codes[static_cast<size_t>(k)]) *
                       std::ldexp(1.0f, drop[static_cast<size_t>(k % 10)] - 30);
    ASSERT_EQ(std::bit_cast<uint32_t>(fast[static_cast<size_t>(k)]), std::bit_cast<uint32_t>(want));
  }
}

TEST(CompactViews, AppendingKeepsEveryView) {
  std::mt19937 rng(kSeed);
  const Eigen::MatrixXf a = RandomViews(rng, 12, 3, 0.01f), b = RandomViews(rng, 12, 4, 0.01f),
                        c = RandomViews(rng, 12, 2, 50.0f);  // another power of two
  CompactViews ab(a);
  ab.Append(CompactViews(b));
  ASSERT_EQ(ab.cols(), 7);
  // The same powers of two (views of one place, appended again): the codes as they are.
  CompactViews aa(a);
  aa.Append(CompactViews(a));
  ASSERT_EQ(aa.cols(), 6);
  EXPECT_EQ(aa.Decoded().leftCols(3), CompactViews(a).Decoded());
  EXPECT_EQ(aa.Decoded().rightCols(3), CompactViews(a).Decoded());
  EXPECT_TRUE(ab.Decoded().leftCols(3).isApprox(a, 1e-2f));
  EXPECT_TRUE(ab.Decoded().rightCols(4).isApprox(b, 1e-2f));
  CompactViews abc = ab;
  abc.Append(CompactViews(c));
  ASSERT_EQ(abc.cols(), 9);
  EXPECT_TRUE(abc.Decoded().rightCols(2).isApprox(c, 1e-2f));
  EXPECT_LE((abc.Decoded().leftCols(7) - ab.Decoded()).cwiseAbs().maxCoeff(),
            abc.Decoded().cwiseAbs().maxCoeff() * 0x1p-7f);
  CompactViews empty;
  empty.Append(CompactViews(a));
  EXPECT_EQ(empty, CompactViews(a));
  EXPECT_THROW(ab.Append(CompactViews(Eigen::MatrixXf::Ones(5, 1))), std::invalid_argument);
}

// The store and the messages keep views in their 16-bit form: the form of an encoding gives
// it back, views on the finer 16-bit grid of tscd before 8 bits are encoded again, and parts
// no encoding gives are refused.
TEST(CompactViews, FromTheirSixteenBitFormOnlyWhatEncodingGives) {
  std::mt19937 rng(kSeed);
  const CompactViews views(RandomViews(rng, 9, 4, 0.02f));
  const std::vector<int16_t> wide = views.Wide();
  EXPECT_EQ(CompactViews(9, 4, views.shift(), wide), views);
  EXPECT_EQ(CompactViews(2, 1, 0, {0, 0}), CompactViews(Eigen::MatrixXf::Zero(2, 1)));
  EXPECT_THROW(CompactViews(9, 3, views.shift(), wide), std::invalid_argument);  // sizes
  EXPECT_THROW(CompactViews(1, 1, 3, {5}), std::invalid_argument);               // too small
  EXPECT_THROW(CompactViews(1, 1, 3, {-32768}), std::invalid_argument);          // too large
  EXPECT_THROW(CompactViews(1, 1, -16, {20000}), std::invalid_argument);         // 2^30 up
  EXPECT_THROW(CompactViews(2, 1, 7, {0, 0}), std::invalid_argument);            // zero, shifted
  // 20000 is on the 16-bit grid, not on the 8-bit one: the nearest code, 78 · 2^8.
  const CompactViews finer(1, 1, 0, {20000});
  EXPECT_EQ(finer.Decoded()(0, 0), 19968.0f);
  EXPECT_EQ(finer.Wide(), std::vector<int16_t>{19968});
  // A row of small values stays on the 16-bit grid beside a large one.
  EXPECT_EQ(CompactViews(2, 1, 0, {20224, 101}).Wide(), (std::vector<int16_t>{20224, 101}));
}

// Views too small for the grid of the largest shift keep what the grid holds, exactly again.
TEST(CompactViews, TinyViewsRoundTripAtTheLargestShift) {
  const Eigen::MatrixXf tiny = Eigen::MatrixXf::Constant(3, 2, 1e-40f);
  const CompactViews once(tiny);
  EXPECT_EQ(once.shift(), 140);
  EXPECT_NEAR(once.Decoded()(0, 0), 1e-40f, 0x1p-140f);
  EXPECT_EQ(CompactViews(once.Decoded()), once);
}

TEST(CompactViews, RefusesWhatItCannotKeep) {
  Eigen::MatrixXf views = Eigen::MatrixXf::Ones(4, 2);
  views(1, 1) = NAN;
  EXPECT_THROW(CompactViews{views}, std::invalid_argument);
  views(1, 1) = INFINITY;
  EXPECT_THROW(CompactViews{views}, std::invalid_argument);
  views(1, 1) = 0x1p31f;
  EXPECT_THROW(CompactViews{views}, std::invalid_argument);
  // The largest the 16-bit form holds at its least shift, and just above it.
  views(1, 1) = 0x1.fdfffep29f;
  const CompactViews largest(views);
  EXPECT_EQ(CompactViews(largest.rows(), largest.cols(), largest.shift(), largest.Wide()), largest);
  views(1, 1) = 0x1.fep29f;
  EXPECT_THROW(CompactViews{views}, std::invalid_argument);
  EXPECT_EQ(CompactViews(Eigen::MatrixXf::Zero(3, 3)).Decoded(), Eigen::MatrixXf::Zero(3, 3));
  EXPECT_THROW(CompactViews(Eigen::MatrixXf::Ones(4, 2)).Col(2), std::out_of_range);
}

// A merge re-encodes the views of every place it absorbs into: in the storage the place held,
// so it leaves no hole glibc cannot hand back (issue 23's RSS after a merge).
TEST(CompactViews, EncodingInPlaceIsTheConstructorsEncodingInTheSameStorage) {
  std::mt19937 rng(kSeed);
  CompactViews held(RandomViews(rng, 128, 64, 0.01f));
  const int8_t* storage = held.codes();
  for (float scale : {1e-9f, 0.01f, 3e4f}) {
    const Eigen::MatrixXf views = RandomViews(rng, 128, 64, scale);
    held.Encode(views);
    EXPECT_EQ(held, CompactViews(views)) << scale;
    EXPECT_EQ(held.codes(), storage) << "views of the same size took new storage";
  }
  // Fewer views fit too; more take new storage, and are still the constructor's.
  const Eigen::MatrixXf fewer = RandomViews(rng, 128, 20, 1.0f);
  held.Encode(fewer);
  EXPECT_EQ(held, CompactViews(fewer));
  EXPECT_EQ(held.codes(), storage);
  const Eigen::MatrixXf more = RandomViews(rng, 128, 80, 1.0f);
  held.Encode(more);
  EXPECT_EQ(held, CompactViews(more));
  // What cannot be kept is refused before the views held change.
  Eigen::MatrixXf bad = RandomViews(rng, 16, 3, 1.0f);
  bad(5, 2) = NAN;
  EXPECT_THROW(held.Encode(bad), std::invalid_argument);
  bad(5, 2) = 0x1p31f;
  EXPECT_THROW(held.Encode(bad), std::invalid_argument);
  EXPECT_EQ(held, CompactViews(more));
}

}  // namespace
}  // namespace tsc

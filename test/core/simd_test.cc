#include "core/memory/simd.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <iostream>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

namespace tsc {
namespace {

constexpr uint32_t kSeed = 20240611;

// Descriptor-like data: positive entries on the scale of a sum-normalised descriptor.
Eigen::MatrixXf Random(std::mt19937& rng, int rows, int cols) {
  std::uniform_real_distribution<float> u(0.0f, 2.0f / 1200.0f);
  Eigen::MatrixXf m(rows, cols);
  for (Eigen::Index i = 0; i < m.size(); ++i) m.data()[i] = u(rng);
  return m;
}

// The rounding bound of a float sum of products x_i·y_i accumulated `terms` deep (plus the
// three additions that fold 8 lanes): (terms + 3)·ε·Σ|x_i y_i|.
double Tolerance(const Eigen::VectorXf& x, const Eigen::VectorXf& y, int terms) {
  const double magnitude =
      (x.cwiseAbs().cast<double>().array() * y.cwiseAbs().cast<double>().array()).sum();
  return (terms + 3) * static_cast<double>(std::numeric_limits<float>::epsilon()) * magnitude;
}

// ColumnDots sums each of 8 lanes over every 8th dimension.
int LaneTerms(int dim) { return (dim + 7) / 8; }

class AvxKernels : public ::testing::Test {
 protected:
  void SetUp() override {
    if (FastestSimd() != Simd::kAvx2Fma) GTEST_SKIP() << "the CPU has no AVX2 and FMA";
    std::cout << "seed " << kSeed << "\n";
  }
  std::mt19937 rng_{kSeed};
};

TEST(Simd, FastestIsPortableOrAvxAndStaysTheSame) {
  const Simd first = FastestSimd();
  EXPECT_TRUE(first == Simd::kPortable || first == Simd::kAvx2Fma);
  EXPECT_EQ(FastestSimd(), first);
  // 16 lanes only on top of AVX2 and FMA.
  EXPECT_TRUE(WidestLanes() == Lanes::k8 || first == Simd::kAvx2Fma);
  EXPECT_EQ(WidestLanes(), WidestLanes());
}

// Every block shape and tail: sizes around the kernel's 4 x 3 blocks and 8 lanes.
TEST_F(AvxKernels, ColumnDotsEqualTheEigenProductOnRandomData) {
  for (int dim : {1, 7, 8, 9, 17, 1200}) {
    for (int na : {1, 2, 3, 4, 5, 9, 32}) {
      for (int nb : {1, 2, 3, 4, 7, 32}) {
        const Eigen::MatrixXf a = Random(rng_, dim, na), b = Random(rng_, dim, nb);
        Eigen::MatrixXf out(na, nb);
        Eigen::VectorXf norms(nb);
        avx2::ColumnDots(a.data(), na, b.data(), nb, dim, out.data(), norms.data());
        const Eigen::MatrixXd want = a.cast<double>().transpose() * b.cast<double>();
        for (int j = 0; j < nb; ++j) {
          EXPECT_NEAR(norms[j], b.col(j).cast<double>().squaredNorm(),
                      Tolerance(b.col(j), b.col(j), LaneTerms(dim)))
              << "dim " << dim << " column " << j;
          for (int i = 0; i < na; ++i) {
            ASSERT_NEAR(out(i, j), want(i, j), Tolerance(a.col(i), b.col(j), LaneTerms(dim)))
                << "dim " << dim << ", " << na << " x " << nb << " at " << i << ", " << j;
          }
        }
      }
    }
  }
}

// A product does not depend on where its columns fall in the blocks or in the bands of long
// columns of a (53 columns of 1200 floats are taken 24 at a time), and the memory to prefetch
// does not change it: a full block's sums, taken together, are a lone column's sum bit for bit,
// on either width.
TEST_F(AvxKernels, ColumnDotsOfAColumnAreTheSameInEveryBlock) {
  std::vector<Lanes> widths = {Lanes::k8};
  if (WidestLanes() == Lanes::k16) widths.push_back(Lanes::k16);
  for (Lanes lanes : widths) {
    for (int dim : {9, 128, 1200}) {
      const int na = 53, nb = 10;
      const Eigen::MatrixXf a = Random(rng_, dim, na), b = Random(rng_, dim, nb);
      Eigen::MatrixXf all(na, nb);
      Eigen::VectorXf norms(nb);
      avx2::ColumnDots(a.data(), na, b.data(), nb, dim, all.data(), norms.data(), b.data(),
                       b.size(), lanes);
      for (int j = 0; j < nb; ++j) {
        float norm = 0.0f, dot = 0.0f;
        avx2::ColumnDots(b.col(j).data(), 1, b.col(j).data(), 1, dim, &dot, &norm, nullptr, 0,
                         lanes);
        EXPECT_EQ(norm, norms[j]) << "norm of " << j;
        for (int i = 0; i < na; ++i) {
          float one = 0.0f;
          avx2::ColumnDots(a.col(i).data(), 1, b.col(j).data(), 1, dim, &one, nullptr, nullptr, 0,
                           lanes);
          ASSERT_EQ(one, all(i, j))
              << (lanes == Lanes::k16 ? 16 : 8) << " lanes, dim " << dim << ", " << i << ", " << j;
        }
      }
    }
  }
}

// 16 lanes run the 8-lane sums two at a time: the same floats bit for bit, at every block
// shape and tail (odd counts of columns, dimensions that are no multiple of 8).
TEST_F(AvxKernels, ColumnDotsOnSixteenLanesAreTheEightLanesBitForBit) {
  if (WidestLanes() != Lanes::k16) GTEST_SKIP() << "the CPU has no AVX-512F and VL";
  for (int dim : {1, 7, 8, 9, 17, 128, 1200}) {
    for (int na : {1, 2, 3, 4, 5, 9, 12, 53}) {  // 53: bands of long columns
      for (int nb : {1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 16, 17, 32}) {
        const Eigen::MatrixXf a = Random(rng_, dim, na), b = Random(rng_, dim, nb);
        Eigen::MatrixXf out8(na, nb), out16(na, nb);
        Eigen::VectorXf norms8(nb), norms16(nb);
        avx2::ColumnDots(a.data(), na, b.data(), nb, dim, out8.data(), norms8.data(), nullptr, 0,
                         Lanes::k8);
        avx2::ColumnDots(a.data(), na, b.data(), nb, dim, out16.data(), norms16.data(), b.data(),
                         b.size(), Lanes::k16);
        for (int j = 0; j < nb; ++j) {
          ASSERT_EQ(norms8[j], norms16[j]) << "dim " << dim << " column " << j;
          for (int i = 0; i < na; ++i) {
            ASSERT_EQ(out8(i, j), out16(i, j))
                << "dim " << dim << ", " << na << " x " << nb << " at " << i << ", " << j;
          }
        }
      }
    }
  }
}

TEST_F(AvxKernels, RowDotsEqualTheEigenProductOnRandomData) {
  for (int dim : {1, 5, 32}) {
    for (int rows : {1, 7, 8, 9, 31, 32, 33, 100, 1024}) {
      for (int nq : {1, 2, 3, 4, 7}) {
        // A block of a taller matrix: the leading dimension exceeds the rows.
        const Eigen::MatrixXf tall = Random(rng_, rows + 13, dim);
        const Eigen::MatrixXf q = Random(rng_, dim, nq);
        Eigen::MatrixXf out(rows, nq);
        avx2::RowDots(tall.data() + 5, tall.rows(), rows, dim, q.data(), nq, out.data());
        const Eigen::MatrixXf a = tall.middleRows(5, rows);
        const Eigen::MatrixXd want = a.cast<double>() * q.cast<double>();
        for (int j = 0; j < nq; ++j) {
          for (int r = 0; r < rows; ++r) {
            // RowDots sums each row over the dimensions in order.
            ASSERT_NEAR(out(r, j), want(r, j), Tolerance(a.row(r).transpose(), q.col(j), dim))
                << "dim " << dim << ", " << rows << " rows x " << nq << " at " << r << ", " << j;
          }
        }
      }
    }
  }
}

// Each row's sum is one lane's FMAs over the dimensions in order at either width: 16 lanes give
// the 8-lane floats bit for bit, for blocks of 64 rows, every masked tail and 1-7 queries.
TEST_F(AvxKernels, RowDotsOnSixteenLanesAreTheEightLanesBitForBit) {
  if (WidestLanes() != Lanes::k16) GTEST_SKIP() << "the CPU has no AVX-512F and VL";
  for (int dim : {1, 5, 128}) {
    for (int rows : {1, 15, 16, 17, 63, 64, 65, 100, 1024}) {
      for (int nq : {1, 2, 3, 4, 5, 7}) {
        const Eigen::MatrixXf tall = Random(rng_, rows + 13, dim);
        const Eigen::MatrixXf q = Random(rng_, dim, nq);
        Eigen::MatrixXf out8(rows, nq), out16(rows, nq);
        avx2::RowDots(tall.data() + 5, tall.rows(), rows, dim, q.data(), nq, out8.data(),
                      Lanes::k8);
        avx2::RowDots(tall.data() + 5, tall.rows(), rows, dim, q.data(), nq, out16.data(),
                      Lanes::k16);
        for (int j = 0; j < nq; ++j) {
          for (int r = 0; r < rows; ++r) {
            ASSERT_EQ(out8(r, j), out16(r, j))
                << "dim " << dim << ", " << rows << " rows x " << nq << " at " << r << ", " << j;
          }
        }
      }
    }
  }
}

// A key's least distance over the queries: the scalar loop's floats on 8 lanes and portably, for
// every tail of the 8 lanes and 0-5 queries.
TEST_F(AvxKernels, LeastDistancesAreTheScalarLoopsBitForBit) {
  for (int rows : {1, 7, 8, 9, 33, 1024}) {
    for (int nq : {0, 1, 2, 3, 5}) {
      const Eigen::MatrixXf dots = Random(rng_, rows, std::max(nq, 1));
      const Eigen::VectorXf q_norms = Random(rng_, std::max(nq, 1), 1).cwiseAbs();
      std::vector<float> got(static_cast<size_t>(rows));
      std::vector<float> portable(static_cast<size_t>(rows));
      avx2::LeastDistances(dots.data(), rows, nq, q_norms.data(), got.data());
      LeastDistances(Simd::kPortable, dots.data(), rows, nq, q_norms.data(), portable.data());
      for (int r = 0; r < rows; ++r) {
        float want = std::numeric_limits<float>::infinity();
        for (int j = 0; j < nq; ++j) want = std::min(want, q_norms[j] - 2.0f * dots(r, j));
        ASSERT_EQ(got[static_cast<size_t>(r)], want) << rows << " rows, " << nq << " at " << r;
        ASSERT_EQ(portable[static_cast<size_t>(r)], want) << "portable, " << rows << " rows";
      }
    }
  }
}

// The nearest column by ‖x‖² + ‖y‖² − 2xᵀy: the same floats and columns as the scalar loop of
// ViewDistances, for every tail of the 8 lanes, with ties (the first column wins) and a NaN
// (it neither replaces nor is replaced).
TEST_F(AvxKernels, NearestColumnsAreTheScalarLoopsBitForBit) {
  for (int n : {1, 7, 8, 9, 32, 33}) {
    for (int k : {1, 2, 5, 64}) {
      Eigen::MatrixXf dots = Random(rng_, n, k);
      Eigen::VectorXf col_sq = Random(rng_, k, 1);
      const Eigen::VectorXf row_sq = Random(rng_, n, 1);
      if (k > 2) {  // a tie: column 1 stays the nearer of the two
        dots.col(2) = dots.col(1);
        col_sq[2] = col_sq[1];
        dots(0, 1) = dots(0, 2) = 1.0f;  // and, in row 0, the nearest of all
      }
      if (k > 4) dots(0, 3) = std::numeric_limits<float>::quiet_NaN();
      if (k > 1 && n > 1) dots(1, 0) = std::numeric_limits<float>::quiet_NaN();
      std::vector<float> nearest(static_cast<size_t>(n));
      std::vector<int> at(static_cast<size_t>(n));
      avx2::NearestColumns(dots.data(), n, k, col_sq.data(), row_sq.data(), nearest.data(),
                           at.data());
      for (int j = 0; j < n; ++j) {
        float want = (-2.0f * dots(j, 0) + col_sq[0]) + row_sq[j];
        int want_at = 0;
        for (int v = 1; v < k; ++v) {
          const float d = (-2.0f * dots(j, v) + col_sq[v]) + row_sq[j];
          if (d < want) {
            want = d;
            want_at = v;
          }
        }
        const auto where = ::testing::Message() << n << " x " << k << " at row " << j;
        if (std::isnan(want)) {
          EXPECT_TRUE(std::isnan(nearest[static_cast<size_t>(j)])) << where;
        } else {
          EXPECT_EQ(nearest[static_cast<size_t>(j)], want) << where;
        }
        EXPECT_EQ(at[static_cast<size_t>(j)], want_at) << where;
      }
    }
  }
}

// The encoding's passes (CompactViews) against their scalar definitions: every 8-lane and
// 4-lane tail, negative coordinates, and codes exactly halfway between integers (ties go to
// even, as the default rounding mode does).
TEST_F(AvxKernels, RowMagnitudesAreTheLargestAndSeeEveryNonFiniteCoordinate) {
  for (int rows : {1, 3, 8, 9, 17, 64}) {
    for (int cols : {1, 2, 33}) {
      Eigen::MatrixXf x = Random(rng_, rows, cols) - Random(rng_, rows, cols);
      std::vector<float> most(static_cast<size_t>(rows));
      ASSERT_TRUE(avx2::RowMagnitudes(x.data(), rows, cols, most.data()));
      for (int r = 0; r < rows; ++r) {
        EXPECT_EQ(most[static_cast<size_t>(r)], x.row(r).cwiseAbs().maxCoeff()) << rows << " " << r;
      }
      for (float bad :
           {std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
            std::numeric_limits<float>::quiet_NaN()}) {
        for (int r : {0, rows - 1}) {  // in the 8-lane part and in the tail
          Eigen::MatrixXf y = x;
          y(r, cols - 1) = bad;
          EXPECT_FALSE(avx2::RowMagnitudes(y.data(), rows, cols, most.data()))
              << rows << " x " << cols << ", row " << r << ": " << bad;
        }
      }
    }
  }
}

TEST_F(AvxKernels, RoundInt8RowsRoundsTheExactProductsToNearestEven) {
  std::uniform_int_distribution<int> half_steps(-254, 254);  // codes in [−127, 127], halves too
  std::uniform_int_distribution<int> exponent(-20, 20);
  for (int rows : {1, 3, 4, 5, 8, 64, 67}) {
    for (int cols : {1, 2, 9}) {
      std::vector<double> scale(static_cast<size_t>(rows));
      for (double& s : scale) s = std::ldexp(1.0, exponent(rng_));
      Eigen::MatrixXf x(rows, cols);
      for (int c = 0; c < cols; ++c) {
        for (int r = 0; r < rows; ++r) {
          // Half of them exact halves (k/2 / scale), the rest anywhere between.
          const double code = (r + c) % 2 == 0
                                  ? half_steps(rng_) / 2.0
                                  : std::uniform_real_distribution<double>(-127.4, 127.4)(rng_);
          x(r, c) = static_cast<float>(code / scale[static_cast<size_t>(r)]);
        }
      }
      std::vector<int8_t> codes(static_cast<size_t>(rows * cols));
      avx2::RoundInt8Rows(x.data(), rows, cols, scale.data(), codes.data());
      for (int c = 0; c < cols; ++c) {
        for (int r = 0; r < rows; ++r) {
          const double want =
              std::nearbyint(static_cast<double>(x(r, c)) * scale[static_cast<size_t>(r)]);
          EXPECT_EQ(codes[static_cast<size_t>(r + c * rows)], static_cast<int8_t>(want))
              << rows << " x " << cols << " at " << r << ", " << c << ": " << x(r, c);
        }
      }
    }
  }
}

// The median by ranks is std::nth_element's element at n/2 for every count around the 4 lanes
// and their tail, with ties (values drawn from a few levels) and infinities, and leaves the
// values in their order.
TEST_F(AvxKernels, UpperMedianIsTheElementNthElementPutsInTheMiddle) {
  for (int n = 1; n <= 70; ++n) {
    for (int levels : {3, 1000}) {
      std::vector<double> values(static_cast<size_t>(n));
      std::uniform_int_distribution<int> level(0, levels - 1);
      for (double& v : values) {
        const int l = level(rng_);
        v = l == 0 && levels == 3 ? std::numeric_limits<double>::infinity() : l * 0.25;
      }
      const std::vector<double> before = values;
      std::vector<double> sorted = values;
      std::nth_element(sorted.begin(), sorted.begin() + n / 2, sorted.end());
      EXPECT_EQ(avx2::UpperMedian(values.data(), n), sorted[static_cast<size_t>(n / 2)])
          << n << " values of " << levels << " levels";
      EXPECT_EQ(values, before);
    }
  }
  EXPECT_THROW(avx2::UpperMedian(nullptr, 0), std::invalid_argument);
}

// The least value and its first index are a scalar loop's `v < least` for every count around
// the 8 lanes and their tail, with ties (few levels), infinities and NaNs (never the least).
TEST_F(AvxKernels, LeastAndFirstLeastAreTheScalarLoops) {
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int n = 0; n <= 40; ++n) {
    for (int levels : {2, 4, 1000}) {
      std::vector<float> values(static_cast<size_t>(n));
      std::uniform_int_distribution<int> level(0, levels - 1);
      for (float& v : values) {
        const int l = level(rng_);
        v = levels == 4 && l == 0 ? nan : levels == 2 && l == 1 ? inf : static_cast<float>(l);
      }
      float least = inf;
      int at = -1;
      for (int i = 0; i < n; ++i) {
        if (values[static_cast<size_t>(i)] < least) {
          least = values[static_cast<size_t>(i)];
          at = i;
        }
      }
      EXPECT_EQ(avx2::Least(values.data(), n), least) << n << " values of " << levels;
      EXPECT_EQ(avx2::FirstLeast(values.data(), n), at) << n << " values of " << levels;
    }
  }
  const std::vector<float> none = {inf, nan, inf};
  EXPECT_EQ(avx2::Least(none.data(), 3), inf);
  EXPECT_EQ(avx2::FirstLeast(none.data(), 3), -1);
}

}  // namespace
}  // namespace tsc

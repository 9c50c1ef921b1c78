// The store's blob layouts (store/layouts.h): each value the store writes is read back as it
// was (random values from a printed seed), and a cell no encoder writes is refused with a
// BlobError saying why, before anything of the size it claims is allocated.

#include "store/layouts.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <iostream>
#include <limits>
#include <random>
#include <span>
#include <vector>

namespace tsc::store_internal {
namespace {

constexpr std::uint32_t kSeed = 20261201;

/// Decodes `bytes` with `decode`, requiring every byte read.
template <typename F>
auto Read(const Bytes& bytes, F&& decode) {
  BlobReader r{std::span<const unsigned char>(bytes)};
  auto out = decode(r);
  EXPECT_EQ(r.remaining(), 0u);
  return out;
}

/// The BlobError `decode` throws on `bytes`, or "" when it decodes.
template <typename F>
std::string Refusal(const Bytes& bytes, F&& decode) {
  BlobReader r{std::span<const unsigned char>(bytes)};
  try {
    decode(r);
  } catch (const BlobError& e) {
    return e.what();
  }
  return "";
}

TEST(Layouts, EachValueIsReadBackAsWritten) {
  std::cout << "seed " << kSeed << "\n";
  std::mt19937 rng(kSeed);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  for (int round = 0; round < 20; ++round) {
    const int rows = 1 + static_cast<int>(rng() % 50), cols = 1 + static_cast<int>(rng() % 9);
    Eigen::MatrixXf m(rows, cols);
    for (Eigen::Index i = 0; i < m.size(); ++i) m.data()[i] = unit(rng);
    const Eigen::VectorXf v = m.col(0);

    EXPECT_EQ(Read(EncodeFloats(v), [](BlobReader& r) { return DecodeVector(r); }), v);
    EXPECT_EQ(Read(EncodeFloats(v), [&](BlobReader& r) { return DecodeVector(r, rows); }), v);
    EXPECT_EQ(Read(EncodeFloats(m), [&](BlobReader& r) { return DecodeMatrix(r, rows, cols); }), m);

    const CompactViews views(m);
    const CompactViews samples = Read(EncodeSamples(views), DecodeSamples);
    EXPECT_EQ(samples.shift(), views.shift());
    EXPECT_EQ(samples.Decoded(), views.Decoded());

    std::vector<TransitionRegion> regions(rng() % 5);
    for (TransitionRegion& t : regions) {
      t.first = static_cast<int64_t>(rng()) << 20;
      t.last = t.first + static_cast<int64_t>(rng() % 100);
    }
    const std::vector<TransitionRegion> back = Read(EncodeTransitions(regions), DecodeTransitions);
    ASSERT_EQ(back.size(), regions.size());
    for (size_t i = 0; i < back.size(); ++i) {
      EXPECT_EQ(back[i].first, regions[i].first);
      EXPECT_EQ(back[i].last, regions[i].last);
    }

    std::vector<PlaceId> sources(rng() % 5);
    for (PlaceId& id : sources)
      id = PlaceId{static_cast<uint32_t>(rng()), static_cast<uint32_t>(rng())};
    EXPECT_EQ(Read(EncodeSources(sources), DecodeSources), sources);

    Slink slink;
    std::vector<double> distances;
    for (int n = 0; n < rows; ++n) {
      slink.Insert(distances);
      distances.push_back(std::abs(unit(rng)) + 0.01);
      for (double& d : distances) d = std::abs(unit(rng)) + 0.01;
    }
    const Slink read = Read(EncodeSlink(slink), [&](BlobReader& r) {
      return DecodeSlink(r, static_cast<size_t>(rows));
    });
    EXPECT_EQ(read.pi(), slink.pi());
    EXPECT_EQ(read.lambda(), slink.lambda());
  }
}

// Schema versions before 4 kept member views as int32 rows, int32 cols, float32 values.
TEST(Layouts, SamplesOfTheFloatLayoutAreRead) {
  Eigen::MatrixXf m(3, 2);
  m << 0.5f, -0.25f, 0.125f, 0.75f, 0.0f, -1.0f / 3.0f;
  const Bytes old = BlobWriter()
                        .PutOne<int32_t>(3)
                        .PutOne<int32_t>(2)
                        .Put(std::span<const float>(m.data(), 6))
                        .Finish();
  EXPECT_EQ(Read(old, DecodeSamples).Decoded(), CompactViews(m).Decoded());
}

TEST(Layouts, CellsNoEncoderWritesAreRefused) {
  const auto vector = [](int64_t dim) {
    return [dim](BlobReader& r) { return DecodeVector(r, dim); };
  };
  const Eigen::VectorXf three = Eigen::VectorXf::Constant(3, 0.5f);
  EXPECT_EQ(Refusal(EncodeFloats(three), vector(4)), "blob of 12 bytes is not 4 float32 values");
  EXPECT_EQ(Refusal(Bytes{1, 2, 3}, vector(-1)),
            "blob of 3 bytes is not a whole number of float32 values");
  Eigen::VectorXf nan = three;
  nan[1] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(Refusal(EncodeFloats(nan), vector(3)), "non-finite value");

  const Eigen::MatrixXf m = Eigen::MatrixXf::Constant(2, 3, 0.25f);
  EXPECT_EQ(Refusal(EncodeFloats(m), [](BlobReader& r) { return DecodeMatrix(r, 3, 3); }),
            "blob of 24 bytes is not 3 x 3 float32 values");
  EXPECT_EQ(Refusal(EncodeFloats(m), [](BlobReader& r) { return DecodeMatrix(r, -2, -3); }),
            "blob of 24 bytes is not -2 x -3 float32 values");

  // Member views claiming more than the cell holds, or negative, or not an encoding.
  const auto samples = [](int32_t marker, int32_t rows, int32_t cols, int32_t shift) {
    return BlobWriter().PutOne(marker).PutOne(rows).PutOne(cols).PutOne(shift).Finish();
  };
  EXPECT_EQ(Refusal(samples(-1, 1 << 30, 1 << 30, 0), DecodeSamples),
            "1073741824 x 1073741824 values need 2305843009213693952 bytes, 0 left");
  EXPECT_EQ(Refusal(samples(-1, -4, 2, 0), DecodeSamples), "views of size -4 x 2: at least 1 x 1");
  // No views of no values, however many they claim: they hold no bytes, but 0 x 2·10⁹ views
  // took seconds to walk (fuzz_store), in both layouts.
  EXPECT_EQ(Refusal(samples(-1, 0, 2137390848, 0), DecodeSamples),
            "views of size 0 x 2137390848: at least 1 x 1");
  EXPECT_EQ(
      Refusal(BlobWriter().PutOne(int32_t{0}).PutOne(int32_t{2137390848}).Finish(), DecodeSamples),
      "views of size 0 x 2137390848: at least 1 x 1");
  EXPECT_EQ(Refusal(samples(-1, 128, 0, 0), DecodeSamples),
            "views of size 128 x 0: at least 1 x 1");
  Bytes not_encoding = samples(-1, 1, 1, 0);
  for (const unsigned char b : EncodeArray(std::span<const int16_t>({int16_t{3}}))) {
    not_encoding.push_back(b);
  }
  EXPECT_NE(Refusal(not_encoding, DecodeSamples), "");  // largest |value| below 2^14
  Bytes trailing = EncodeSamples(CompactViews(m));
  trailing.push_back(0);
  EXPECT_NE(Refusal(trailing, DecodeSamples).find("trailing bytes"), std::string::npos);

  // Pairs cut in half.
  EXPECT_EQ(Refusal(EncodeArray(std::span<const int64_t>({int64_t{1}, int64_t{2}, int64_t{3}})),
                    DecodeTransitions),
            "odd number of region bounds");
  EXPECT_EQ(Refusal(EncodeArray(std::span<const uint32_t>({1u})), DecodeSources),
            "odd number of robot/local values");

  // A SLINK state of another size, or one SLINK never builds (a point above itself).
  Slink two;
  two.Insert({});
  two.Insert({0.5});
  const auto slink_of = [](size_t n) { return [n](BlobReader& r) { return DecodeSlink(r, n); }; };
  EXPECT_EQ(Refusal(EncodeSlink(two), slink_of(3)),
            "blob of 24 bytes is not a SLINK state of 3 places");
  const Bytes forged = BlobWriter()
                           .Put(std::span<const int32_t>({int32_t{0}, int32_t{0}}))
                           .Put(std::span<const double>({0.5, 0.5}))
                           .Finish();
  EXPECT_NE(Refusal(forged, slink_of(2)), "");
}

}  // namespace
}  // namespace tsc::store_internal

// The store's blobs (store/blob.h): what a writer puts, a reader takes back bit for bit, in
// the order it was put; little-endian on disk whatever the machine; a reader refuses, with its
// size, a blob cut short, one with bytes left over and one that is not a whole number of values.

#include "store/blob.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <iostream>
#include <limits>
#include <random>
#include <span>
#include <vector>

namespace tsc::store_internal {
namespace {

constexpr std::uint32_t kSeed = 20261201;

TEST(Blob, WhatIsPutIsTakenBackBitForBit) {
  std::cout << "seed " << kSeed << "\n";
  std::mt19937 rng(kSeed);
  for (int round = 0; round < 50; ++round) {
    std::vector<float> floats(rng() % 40);
    for (float& f : floats) {
      const auto bits = static_cast<std::uint32_t>(rng());
      std::memcpy(&f, &bits, sizeof f);  // any bit pattern, NaNs and infinities too
    }
    std::vector<int16_t> shorts(rng() % 40);
    for (int16_t& s : shorts) s = static_cast<int16_t>(rng());
    const double d = std::uniform_real_distribution<double>(-1e300, 1e300)(rng);
    const int64_t big = std::numeric_limits<int64_t>::min() + static_cast<int64_t>(rng());

    const Bytes bytes = BlobWriter()
                            .PutOne<int64_t>(big)
                            .Put(std::span<const float>(floats))
                            .PutOne(d)
                            .Put(std::span<const int16_t>(shorts))
                            .Finish();
    ASSERT_EQ(bytes.size(), 8 + 4 * floats.size() + 8 + 2 * shorts.size());
    BlobReader r(bytes);
    EXPECT_EQ(r.TakeOne<int64_t>(), big);
    const std::vector<float> floats_back = r.Take<float>(floats.size());
    ASSERT_EQ(floats_back.size(), floats.size());
    EXPECT_EQ(std::memcmp(floats_back.data(), floats.data(), floats.size() * sizeof(float)), 0);
    EXPECT_EQ(r.TakeOne<double>(), d);
    EXPECT_EQ(r.TakeRest<int16_t>(), shorts);
    EXPECT_NO_THROW(r.ExpectEnd());
  }
}

TEST(Blob, IsLittleEndianOnDisk) {
  const Bytes bytes = BlobWriter().PutOne<uint32_t>(0x01020304u).PutOne<int16_t>(-2).Finish();
  EXPECT_EQ(bytes, (Bytes{0x04, 0x03, 0x02, 0x01, 0xfe, 0xff}));
}

TEST(Blob, AReaderRefusesWhatDoesNotFit) {
  const Bytes bytes = EncodeArray(std::span<const int32_t>(std::vector<int32_t>{1, 2, 3}));
  {
    BlobReader r(bytes);
    EXPECT_THROW(r.Take<int32_t>(4), BlobError);  // cut short
    EXPECT_EQ(r.remaining(), 12u);                // and nothing taken
  }
  {
    BlobReader r(bytes);
    r.TakeOne<int32_t>();
    EXPECT_THROW(r.ExpectEnd(), BlobError);  // trailing bytes
  }
  {
    BlobReader r(std::span<const unsigned char>(bytes).first(10));
    EXPECT_THROW(r.TakeRest<int32_t>(), BlobError);  // not whole values
  }
  {
    // A count that would overflow count x sizeof(T) is refused, not allocated.
    BlobReader r(bytes);
    EXPECT_THROW(r.Take<double>(std::numeric_limits<size_t>::max() / 4), BlobError);
  }
}

}  // namespace
}  // namespace tsc::store_internal

#include "daemon/known_digests.h"

#include <gtest/gtest.h>

#include <unordered_set>

namespace tsc {
namespace {

TEST(KnownDigests, HoldsEachDigestOnceInOrderWhateverItWasGivenIn) {
  const std::vector<int64_t> given{42, -7, 42, 0, 9000000000LL, -7};
  const KnownDigests dut(given.begin(), given.end());
  EXPECT_EQ(dut.size(), 4u);
  EXPECT_EQ(std::vector<int64_t>(dut.begin(), dut.end()),
            (std::vector<int64_t>{-7, 0, 42, 9000000000LL}));
  for (int64_t d : given) EXPECT_TRUE(dut.contains(d)) << d;
  for (int64_t d : {-8LL, 1LL, 41LL, 43LL, 9000000001LL}) EXPECT_FALSE(dut.contains(d)) << d;
  const std::unordered_set<int64_t> hashed(given.begin(), given.end());
  EXPECT_EQ(KnownDigests(hashed.begin(), hashed.end()), dut);  // the same set, another order
  EXPECT_EQ(KnownDigests(std::vector<int64_t>{0, 42, -7, 9000000000LL}), dut);
  EXPECT_TRUE(KnownDigests().empty());
  EXPECT_FALSE(KnownDigests().contains(0));
}

}  // namespace
}  // namespace tsc

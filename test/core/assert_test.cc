// TSC_ASSERT (core/assert.h): armed, a false invariant aborts naming the condition, the reason
// and the place; a true one evaluates its condition once and goes on. Armed here whatever the
// build type, so the test means the same in every build.
#define TSCD_ENABLE_ASSERTS 1
#include "core/assert.h"

#include <gtest/gtest.h>

namespace tsc {
namespace {

static_assert(TSC_ASSERTS_ARMED == 1);

TEST(TscAssert, TrueInvariantEvaluatesOnceAndContinues) {
  int evaluated = 0;
  TSC_ASSERT(++evaluated == 1, "counted");
  EXPECT_EQ(evaluated, 1);
}

TEST(TscAssertDeathTest, FalseInvariantAbortsNamingConditionReasonAndPlace) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  const int views = 3;
  EXPECT_DEATH(TSC_ASSERT(views > 4, "a place keeps five views"),
               "internal invariant failed: views > 4 \\(a place keeps five views\\) at "
               ".*assert_test\\.cc:[0-9]+");
}

}  // namespace
}  // namespace tsc

// core/median.h: the upper median is a value of the data (the element at n/2 once ordered);
// the report median averages the two middle values; neither depends on the input's order.
#include "core/median.h"

#include <gtest/gtest.h>

#include <vector>

namespace tsc {
namespace {

TEST(MedianTest, UpperMedianIsTheMiddleValueOrTheUpperOfTwo) {
  EXPECT_EQ(UpperMedian(std::vector<int>{7}), 7);
  EXPECT_EQ(UpperMedian(std::vector<int>{9, 1, 5}), 5);
  EXPECT_EQ(UpperMedian(std::vector<int>{4, 1, 3, 2}), 3);
  EXPECT_DOUBLE_EQ(UpperMedian(std::vector<double>{0.3, 0.1, 0.2, 0.4, 10.0}), 0.3);
}

TEST(MedianTest, InPlaceReordersOnlyItsArgument) {
  const std::vector<double> original{5.0, 4.0, 3.0, 2.0, 1.0};
  std::vector<double> scratch = original;
  EXPECT_DOUBLE_EQ(UpperMedianInPlace(scratch), 3.0);
  EXPECT_DOUBLE_EQ(scratch[2], 3.0);
  std::vector<double> copy = original;
  EXPECT_DOUBLE_EQ(UpperMedian(copy), 3.0);
  EXPECT_EQ(copy, original);
}

TEST(MedianTest, ReportMedianAveragesTheTwoMiddleValuesAndIsZeroForNothing) {
  EXPECT_DOUBLE_EQ(Median({}), 0.0);
  EXPECT_DOUBLE_EQ(Median({2.0}), 2.0);
  EXPECT_DOUBLE_EQ(Median({4.0, 1.0, 3.0, 2.0}), 2.5);
  EXPECT_DOUBLE_EQ(Median({5.0, 1.0, 3.0}), 3.0);
}

}  // namespace
}  // namespace tsc

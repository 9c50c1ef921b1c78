#pragma once
// Medians of measured values (distances, steps, spacings): one definition of "the median"
// for the pipeline's self-set units, so every unit is taken the same way.

#include <algorithm>
#include <cstddef>
#include <vector>

#include "core/assert.h"

namespace tsc {

/// The element at n/2 once ordered (for an even n, the upper of the two middle values): a
/// value that occurs in the data, in O(n). Reorders `values`, which must not be empty; hot
/// loops pass a reused scratch vector.
template <typename T>
T UpperMedianInPlace(std::vector<T>& values) {
  TSC_ASSERT(!values.empty(), "a median of nothing");
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

/// UpperMedianInPlace of a copy.
template <typename T>
T UpperMedian(std::vector<T> values) {
  return UpperMedianInPlace(values);
}

/// The usual median (the mean of the two middle values for an even n), for reports; 0 when
/// nothing was measured.
inline double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  if (values.size() % 2 == 1) return *mid;
  return (*std::max_element(values.begin(), mid) + *mid) / 2;
}

}  // namespace tsc

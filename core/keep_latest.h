#pragma once
// A list that grows with every visit of a long run keeps its latest entries (issue 23).

#include <cstddef>
#include <vector>

namespace tsc {

/// Drops the first entries of `v` (the oldest, for a list that grows at its end) past `n`.
template <class T>
void KeepLatest(std::vector<T>& v, size_t n) {
  if (v.size() > n) v.erase(v.begin(), v.end() - static_cast<std::ptrdiff_t>(n));
}

}  // namespace tsc

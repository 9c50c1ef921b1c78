#include "core/assert.h"

#include <cstdio>
#include <cstdlib>

namespace tsc::internal {

void AssertionFailed(const char* condition, const char* why, const char* file, int line) noexcept {
  // stdio, not iostreams: nothing here may throw or allocate much on the way down.
  std::fprintf(stderr, "tscd: internal invariant failed: %s (%s) at %s:%d\n", condition, why, file,
               line);
  std::fflush(stderr);
  std::abort();
}

}  // namespace tsc::internal

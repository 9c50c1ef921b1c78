#pragma once
// Tests of a property the code does not have yet run only when asked (TSCD_RUN_KNOWN_FAILURES=1):
// skipped with their finding as the message, so CI stays green and the finding stays visible.

#include <cstdlib>
#include <string_view>

namespace tsc::testing_support {

inline bool KnownFailuresRequested() {
  const char* run = std::getenv("TSCD_RUN_KNOWN_FAILURES");
  return run != nullptr && std::string_view(run) == "1";
}

}  // namespace tsc::testing_support

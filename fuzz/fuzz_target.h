#pragma once
// The libFuzzer entry point every target in fuzz/ defines. Built with TSCD_FUZZ=ON (clang)
// libFuzzer drives it; otherwise replay_main.cc runs it over the seed corpus and the
// regression inputs, so the normal test suite replays them too.

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

namespace tsc::fuzz {

/// A property a target checks: when it does not hold, says which and aborts, so libFuzzer
/// keeps the input as a crash and the replay test fails.
inline void Require(bool holds, const char* property) {
  if (holds) return;
  std::fprintf(stderr, "fuzz property violated: %s\n", property);
  std::abort();
}

}  // namespace tsc::fuzz

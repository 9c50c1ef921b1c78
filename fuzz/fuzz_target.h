#pragma once
// The libFuzzer entry point every target in fuzz/ defines. Built with TSCD_FUZZ=ON (clang)
// libFuzzer drives it; otherwise replay_main.cc runs it over the seed corpus and the
// regression inputs, so the normal test suite replays them too.

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);
/// Optional: set-up run once before the first input, outside libFuzzer's per-input timeout
/// (a target whose seed takes seconds to write under ASan). Weak, as libFuzzer declares it.
extern "C" __attribute__((weak)) int LLVMFuzzerInitialize(int* argc, char*** argv);

namespace tsc::fuzz {

/// A property a target checks: when it does not hold, says which and aborts, so libFuzzer
/// keeps the input as a crash and the replay test fails.
inline void Require(bool holds, const char* property) {
  if (holds) return;
  std::fprintf(stderr, "fuzz property violated: %s\n", property);
  std::abort();
}

/// This process's id as 10 digits: scratch file names of one length in every run, so that a
/// fuzz run with a fixed seed takes the same paths through the code (fuzz/short_run.sh).
inline std::string FixedWidthPid() {
  char buf[16];
  std::snprintf(buf, sizeof buf, "%010ld", static_cast<long>(getpid()));
  return buf;
}

/// A target's seed, a `Seed` whose constructor writes it, made on first use: the target
/// defines LLVMFuzzerInitialize with TSC_FUZZ_INITIALIZE_SEED(Seed), so that writing it (a few
/// seconds under ASan on a loaded machine) does not count against the first input's timeout.
template <typename Seed>
const Seed& SeedOf() {
  static const Seed seed;
  return seed;
}

}  // namespace tsc::fuzz

// A C entry point, defined in the target's file.
#define TSC_FUZZ_INITIALIZE_SEED(Seed)                 \
  extern "C" int LLVMFuzzerInitialize(int*, char***) { \
    (void)::tsc::fuzz::SeedOf<Seed>();                 \
    return 0;                                          \
  }

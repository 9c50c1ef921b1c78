#pragma once
// Internal invariants (STYLE 6). Two kinds of checks live in tscd:
// - input checks, always on: a bad value from outside (configuration, a frame, a peer's
//   memory, a caller's argument) throws std::invalid_argument naming it (core/range.h);
// - internal invariants, TSC_ASSERT: what the code itself guarantees and relies on. A failure
//   is a bug in tscd, not bad input, so it aborts with the condition, file and line.
// TSC_ASSERT is armed where assert() is (builds without NDEBUG: Debug and the sanitizer builds
// CI runs) or with TSCD_ENABLE_ASSERTS, and costs nothing otherwise: a hot loop may state what
// it relies on. Disarmed, the condition is still compiled (it cannot rot) but not evaluated.

namespace tsc::internal {

/// Prints "internal invariant failed: <condition> (<why>) at <file>:<line>" and aborts.
[[noreturn]] void AssertionFailed(const char* condition, const char* why, const char* file,
                                  int line) noexcept;

}  // namespace tsc::internal

#if !defined(NDEBUG) || defined(TSCD_ENABLE_ASSERTS)
#define TSC_ASSERTS_ARMED 1
#define TSC_ASSERT(condition, why)    \
  ((condition) ? static_cast<void>(0) \
               : ::tsc::internal::AssertionFailed(#condition, why, __FILE__, __LINE__))
#else
#define TSC_ASSERTS_ARMED 0
#define TSC_ASSERT(condition, why) static_cast<void>(sizeof(static_cast<bool>(condition)))
#endif

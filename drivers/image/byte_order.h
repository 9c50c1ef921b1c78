#pragma once
// Unsigned integers read from image bytes in either byte order: PNG and JPEG headers are
// big-endian, an EXIF block says its own order ("MM" big, "II" little).

#include <cstddef>
#include <cstdint>
#include <span>

namespace tsc {

/// The `bytes`-byte (1..4) unsigned integer at `at` of `b`. Precondition: at + bytes ≤ b.size().
inline uint32_t ReadUnsigned(std::span<const uint8_t> b, size_t at, int bytes,
                             bool little_endian = false) {
  uint32_t v = 0;
  for (int i = 0; i < bytes; ++i) {
    const uint32_t byte = b[at + static_cast<size_t>(i)];
    v |= byte << (8 * (little_endian ? i : bytes - 1 - i));
  }
  return v;
}

}  // namespace tsc

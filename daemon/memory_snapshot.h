#pragma once
// A robot's place memory and map as LCM portions (DESIGN §4): what tscd publishes on
// TSC_MEMORY_<robot> when its memory changes and when a peer asks for it.

#include <cstdint>
#include <vector>

#include "core/map/topological_map.h"
#include "core/memory/place_memory.h"
#include "tsc/memory_portion_t.hpp"

namespace tsc {

struct MemorySnapshot {
  int64_t version = 0;
  int64_t digest = 0;  ///< first 8 bytes of SHA-256 over the portions' encodings (digest = 0)
  std::vector<memory_portion_t> portions;
  int32_t places = 0;
  int32_t edges = 0;
};

struct SnapshotHeader {
  int32_t robot = 0;
  int64_t boot_id = 0;
  int64_t version = 0;
  int64_t utime = 0;
};

/// Cuts `memory` and `map` into portions whose encodings stay within `portion_bytes` (one
/// place larger than that still gets a portion of its own). Deterministic for equal input.
/// Precondition: portion_bytes ≥ 4096.
MemorySnapshot BuildSnapshot(const PlaceMemory& memory, const TopologicalMap& map,
                             const SnapshotHeader& header, int portion_bytes);

/// First 8 bytes (big endian) of SHA-256 over the portions' encodings in order, each taken
/// with utime, boot_id, version and digest zero and no HMAC (content only): what
/// BuildSnapshot puts in `digest` and receivers check.
int64_t SnapshotDigest(const std::vector<memory_portion_t>& portions);

}  // namespace tsc

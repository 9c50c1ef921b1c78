#pragma once
// SplitMix64 (Steele, Lea, Flood 2014): a fixed 64-bit mix with good avalanche, used where
// core needs a deterministic hash or pseudo-random bits that are the same on every machine
// (set keys of memory nodes, the view index's projection).

#include <cstdint>

namespace tsc {

constexpr uint64_t SplitMix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

}  // namespace tsc

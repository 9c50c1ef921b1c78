#pragma once
// A place memory of random places, learned one by one, and its map with the places visited
// in a chain: test input for snapshots, exchange and merging where what the places look like
// does not matter.

#include <random>
#include <utility>

#include "core/map/topological_map.h"
#include "core/memory/place_memory.h"

namespace tsc::testing_support {

struct RandomMemory {
  PlaceMemory memory;
  TopologicalMap map;
};

/// `places` places of `members` uniform random descriptors of `dims` each; the same seed gives
/// the same memory (for any robot: two robots of one seed hold the same places).
inline RandomMemory MakeRandomMemory(uint32_t robot, int places, int dims, unsigned seed,
                                     int members = 10, PlaceMemoryOptions options = {}) {
  RandomMemory out{PlaceMemory(robot, std::move(options)), TopologicalMap{}};
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int p = 0; p < places; ++p) {
    DetectedPlace d;
    d.index = p + 1;
    d.descriptors.resize(dims, members);
    for (int j = 0; j < members; ++j) {
      d.members.push_back(p * 100 + j);
      for (int i = 0; i < dims; ++i) d.descriptors(i, j) = u(rng);
    }
    out.memory.Learn(d);
    const PlaceId id = out.memory.places().back().id;
    out.map.AddPlace(id);
    if (p > 0) out.map.RecordTransition(out.memory.places()[static_cast<size_t>(p - 1)].id, id, {});
  }
  return out;
}

}  // namespace tsc::testing_support

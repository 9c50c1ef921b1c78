#pragma once
// Globally unique place identity: robot id + local number (DESIGN §3.6).

#include <compare>
#include <cstdint>
#include <functional>
#include <string>

namespace tsc {

struct PlaceId {
  uint32_t robot = 0;
  uint32_t local = 0;
  auto operator<=>(const PlaceId&) const = default;
  /// "<robot>:<local>", the form used in events and tools.
  std::string ToString() const { return std::to_string(robot) + ":" + std::to_string(local); }
};

struct PlaceIdHash {
  size_t operator()(const PlaceId& id) const {
    return std::hash<uint64_t>()((uint64_t{id.robot} << 32) | id.local);
  }
};

}  // namespace tsc

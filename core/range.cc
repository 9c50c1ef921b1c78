#include "core/range.h"

#include <charconv>
#include <cmath>
#include <stdexcept>

namespace tsc {

std::string FormatRangeNumber(double v) {
  // Every whole double up to 2^53 is exact, so an integer key's bound reads back as one
  // (sim.start_frame's 1e15 was printed as "1e+15", which an integer key refuses).
  constexpr double kExactWhole = 9007199254740992.0;  // 2^53
  if (v == std::floor(v) && std::abs(v) <= kExactWhole) {
    return std::to_string(static_cast<long long>(v));
  }
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);  // shortest round-trip form
  return std::string(buf, r.ptr);
}

std::string Range::Text() const {
  return std::string(min_open ? "(" : "[") + FormatRangeNumber(min) + ", " +
         FormatRangeNumber(max) + (max_open ? ")" : "]");
}

void Range::Check(std::string_view name, double value) const {
  if (!Contains(value)) {
    throw std::invalid_argument(std::string(name) + " must be in " + Text() + ", got " +
                                FormatRangeNumber(value));
  }
}

}  // namespace tsc

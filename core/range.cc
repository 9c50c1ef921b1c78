#include "core/range.h"

#include <charconv>
#include <cmath>
#include <stdexcept>

namespace tsc {

std::string FormatRangeNumber(double v) {
  if (v == std::floor(v) && std::abs(v) < 1e15) return std::to_string(static_cast<long long>(v));
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

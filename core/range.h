#pragma once
// The valid range of a numeric option, declared once beside the option in its Options struct:
// the struct's Validate() checks it, and the configuration table (settings/) prints it and
// checks values read from files against it.

#include <string>
#include <string_view>

namespace tsc {

/// [min, max], either end open. Not finite values are never inside.
struct Range {
  double min = 0.0;
  double max = 0.0;
  bool min_open = false;  ///< the range excludes min
  bool max_open = false;  ///< the range excludes max

  constexpr bool Contains(double v) const {
    return (min_open ? v > min : v >= min) && (max_open ? v < max : v <= max);
  }
  /// "[0, 1]", "(0, 90]": whole bounds without decimals.
  std::string Text() const;
  /// Throws std::invalid_argument "`name` must be in Text(), got `value`" unless Contains(value).
  void Check(std::string_view name, double value) const;
};

/// A bound or value as the configuration shows it: whole numbers without decimals, others in
/// the shortest form that reads back the same.
std::string FormatRangeNumber(double v);

}  // namespace tsc

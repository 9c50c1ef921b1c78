#pragma once
// Bit-for-bit comparison of what two memories derived from their places (PlaceMemory::Derived):
// the merge, a restore on any number of threads and a snapshot's assembly must each derive
// exactly what a memory computing from scratch derives.

#include <Eigen/Core>
#include <string>

#include "core/memory/place_memory.h"

namespace tsc::testing_support {

namespace derived_compare_detail {

inline bool Same(const Eigen::MatrixXf& a, const Eigen::MatrixXf& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() && a == b;
}

inline bool Same(const Eigen::VectorXf& a, const Eigen::VectorXf& b) {
  return a.size() == b.size() && a == b;
}

}  // namespace derived_compare_detail

/// The fields in which `a` and `b` differ, comma-separated; empty when they are the same.
inline std::string DerivedFieldsDiffering(const PlaceMemory::Derived& a,
                                          const PlaceMemory::Derived& b) {
  using derived_compare_detail::Same;
  std::string fields;
  auto differs = [&](bool same, const char* name) {
    if (same) return;
    if (!fields.empty()) fields += ", ";
    fields += name;
  };
  differs(Same(a.view_centre, b.view_centre), "view_centre");
  differs(a.mean_norm == b.mean_norm, "mean_norm");
  differs(a.spacing == b.spacing, "spacing");
  differs(a.view_radius == b.view_radius, "view_radius");
  differs(Same(a.keys.keys, b.keys.keys), "keys.keys");
  differs(a.keys.norms == b.keys.norms, "keys.norms");
  return fields;
}

/// The first place (by index) whose derived values differ between `x` and `y`, with the
/// fields; empty when every place derived the same. The memories must hold the same places.
inline std::string DerivedDifference(const PlaceMemory& x, const PlaceMemory& y) {
  if (x.places().size() != y.places().size()) {
    return std::to_string(x.places().size()) + " places against " +
           std::to_string(y.places().size());
  }
  for (int p = 0; p < static_cast<int>(x.places().size()); ++p) {
    const std::string fields = DerivedFieldsDiffering(x.DerivedOf(p), y.DerivedOf(p));
    if (!fields.empty()) {
      return "place " + x.places()[static_cast<size_t>(p)].id.ToString() + ": " + fields;
    }
  }
  return {};
}

}  // namespace tsc::testing_support

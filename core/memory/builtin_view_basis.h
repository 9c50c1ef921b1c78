#pragma once
// The view basis compiled into tscd (core/memory/view_basis.h): memory.view_basis = builtin.
// Its axes are core/memory/data/view_basis.bin, written by `tsc basis` from the calibration
// worlds (docs/decisions.md "A principal basis for member views" has the command); the build
// turns the file into constant bytes, so every tscd of one version keeps views alike.

#include <memory>

#include "core/memory/view_basis.h"

namespace tsc {

/// The builtin basis, parsed once (immutable, shared).
std::shared_ptr<const ViewBasis> BuiltinViewBasis();

}  // namespace tsc

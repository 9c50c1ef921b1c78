#pragma once
// `tsc basis`: fits the principal basis member views are kept in (core/memory/view_basis.h,
// docs/decisions.md "A principal basis for member views") on the base points of datasets, and
// says how much of other datasets' descriptors it keeps.

#include <string>
#include <vector>

namespace tsc {

/// Runs `tsc basis --out FILE [--dimension K] [--every N] [--check DIR]... DIR...` with the
/// arguments after the command name. Prints --help and the figures to stdout, errors prefixed
/// "tsc: " to stderr. Returns 0 on success, 1 on a runtime failure (unreadable dataset,
/// unwritable file), 2 on a usage error, 78 on a configuration error. Never throws.
int RunBasisCommand(const std::vector<std::string>& args);

}  // namespace tsc

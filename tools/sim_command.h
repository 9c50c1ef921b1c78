#pragma once
// `tsc sim`: writes a simulated dataset (drivers/world, DESIGN §7.1 and §7.2).

#include <string>
#include <vector>

namespace tsc {

/// Runs `tsc sim` with the arguments after the command name ("--out", "DIR", ...). Prints
/// --help to stdout, errors prefixed "tsc: " to stderr. Returns 0 when the dataset was
/// written, 1 on a runtime failure (e.g. the output folder is not empty or cannot be
/// written), 2 on a usage error (unknown or missing option, bad value). Never throws.
int RunSimCommand(const std::vector<std::string>& args);

}  // namespace tsc

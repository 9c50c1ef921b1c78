#pragma once
// `tsc classify train|test|cv DATASET...`: supervised place classification of thesis chapter 2
// (tools/classify.h, core/classify).

#include <string>
#include <vector>

namespace tsc {

/// Runs `tsc classify` with the arguments after the command name. Prints --help to stdout,
/// the report to stdout and errors prefixed "tsc: " to stderr. Returns 0 on success, 1 on a
/// runtime failure (dataset, model file, I/O), 2 on a usage error, 78 on a configuration
/// error. Never throws.
int RunClassifyCommand(const std::vector<std::string>& args);

}  // namespace tsc

#pragma once
// `tsc merge`: merges two robots' stores offline (core/merge, chapter 4, DESIGN §3.6, §7.2).

#include <string>
#include <vector>

namespace tsc {

/// Runs `tsc merge A.db B.db --out C.db [--force] [--config F] [--set k=v]...` with the
/// arguments after the command name. C is a copy of A (A's robot, its base points and
/// detected places) whose memory and map are A's merged with B's. Prints --help and a summary
/// to stdout, errors prefixed "tsc: " to stderr. Returns 0 on success, 1 on a runtime failure
/// (a store missing, unreadable, of the same robot, or C existing without --force), 2 on a
/// usage error, 78 on a configuration error. Never throws.
int RunMergeCommand(const std::vector<std::string>& args);

}  // namespace tsc

#pragma once
// `tsc axis-sim`: the simulated Axis PTZ camera (tools/simulators/axis_sim.h) as a process.

#include <string>
#include <vector>

namespace tsc {

/// Runs `tsc axis-sim` with the arguments after the command name until SIGINT or SIGTERM.
/// Prints "tsc axis-sim: serving http://127.0.0.1:PORT ..." on stdout once it listens. Returns
/// 0 after a signal, 1 when the port cannot be bound, 2 on a usage error, 78 for an unusable
/// password file. Never throws.
int RunAxisSimCommand(const std::vector<std::string>& args);

}  // namespace tsc

#pragma once
// `tsc jaguar-sim` (the Jaguar board simulator, tools/simulators/jaguar_sim.h) and `tsc teleop`
// (keyboard → JAGUAR_CMD_<robot>, with a dead-man rule).

#include <string>
#include <vector>

namespace tsc {

/// Runs `tsc jaguar-sim` with the arguments after the command name. Prints its ports as
/// "jaguar-sim: udp 127.0.0.1:P tcp 127.0.0.1:Q" on stdout, runs until SIGTERM/SIGINT (or
/// --seconds), prints a summary. Throws UsageError on a bad command line.
int RunJaguarSimCommand(const std::vector<std::string>& args);

/// Runs `tsc teleop`: keys from stdin (raw mode on a terminal; a pipe works the same, so tests
/// script it) become motor commands on JAGUAR_CMD_<robot>. Throws UsageError.
int RunTeleopCommand(const std::vector<std::string>& args);

}  // namespace tsc

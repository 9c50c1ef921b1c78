#pragma once
// `tsc soak`: a bounded soak and load run (issue 8). N tscd robots on the simulated world
// (looping routes) in a private network namespace with an nftables rule dropping a share of
// all UDP datagrams; every R seconds a random robot is stopped (SIGTERM, sometimes SIGKILL)
// and started again from its state database. Every second, per robot: RSS, CPU and the
// daemon's counters (TSC_STATS_<robot>) into OUT/soak.csv; the restarts into
// OUT/restarts.csv; at the end the verdict "no unbounded growth" (tools/soak.h) into
// OUT/soak.json and the picture OUT/soak.png.

#include <string>
#include <vector>

namespace tsc {

/// Runs `tsc soak` with the arguments after the command name. Returns 0 when the soak ran and
/// its verdict is "bounded", 1 when a check failed or on a runtime failure, 2 on a usage
/// error, 78 on a configuration error. Never throws.
int RunSoakCommand(const std::vector<std::string>& args);

}  // namespace tsc

#pragma once
// `tsc team`: a team simulation on one host (DESIGN §4, §7.2). N tscd processes share one
// private network namespace (no packet leaves it), each driving its own route through the same
// simulated world; live progress per robot from their announces; a clean stop; a summary per
// robot (frames, places, recognitions, edges) as text and as OUT/summary.json, a picture of each
// robot's memory and the team map (OUT/team_map.png). `tsc team --offline` is the deterministic
// evaluation: the routes replayed in-process and merged in a given order (tools/team_replay.h).

#include <string>
#include <vector>

namespace tsc {

/// Runs `tsc team` with the arguments after the command name. Returns 0 when every robot ran
/// and stopped cleanly, 1 on a runtime failure, 2 on a usage error, 78 on a configuration
/// error. Never throws.
int RunTeamCommand(const std::vector<std::string>& args);

}  // namespace tsc

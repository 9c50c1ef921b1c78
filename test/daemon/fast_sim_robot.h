#pragma once
// The tscd command line of a small, fast simulated robot for the daemon tests: robot 1,
// 160x120 frames as fast as the pipeline takes them, announces every 0.2 s, and a small
// plenitude threshold (tau_p 3, as keyframes a metre apart get) so the sparse places of a short
// run are not pruned; it learns at once (lcm.join_wait_s 0: a robot alone has no team to rejoin,
// and the crash tests kill it within its first seconds).

#include <filesystem>
#include <string>
#include <vector>

namespace tsc::testing_support {

inline std::vector<std::string> FastSimRobot(const std::filesystem::path& state,
                                             const std::vector<std::string>& extra = {}) {
  std::vector<std::string> argv = {std::string(TSCD_BIN_DIR) + "/tscd",
                                   "--robot",
                                   "1",
                                   "--state-dir",
                                   state.string(),
                                   "--set",
                                   "camera.fps=0",
                                   "--set",
                                   "sim.width=160",
                                   "--set",
                                   "sim.height=120",
                                   "--set",
                                   "lcm.announce_period_s=0.2",
                                   "--set",
                                   "detection.tau_p=3",
                                   "--set",
                                   "lcm.join_wait_s=0"};
  argv.insert(argv.end(), extra.begin(), extra.end());
  return argv;
}

}  // namespace tsc::testing_support

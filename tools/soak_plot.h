#pragma once
// The picture of a soak (`tsc soak`, soak.png): on one time axis in minutes, panels of RSS per
// robot, CPU per robot, places per robot, merges completed per robot and the team's message
// rates per channel family; every restart marked by a dashed line in its robot's colour
// (T: SIGTERM, K: SIGKILL, X: exited on its own).

#include <filesystem>
#include <opencv2/core.hpp>
#include <vector>

#include "tools/soak.h"

namespace tsc {

cv::Mat DrawSoak(const std::vector<SoakSample>& samples, const std::vector<SoakRestart>& restarts,
                 int team_size);

/// Draws and writes the picture. Throws std::runtime_error naming `file` when it cannot be
/// written.
void WriteSoakPlot(const std::vector<SoakSample>& samples, const std::vector<SoakRestart>& restarts,
                   int team_size, const std::filesystem::path& file);

}  // namespace tsc

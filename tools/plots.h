#pragma once
// Pictures of an evaluation (`tsc eval --plots DIR`), drawn with OpenCV on a white
// background:
//   timeline.png    detection timeline (thesis figure 3.3a): one column per frame; rows for
//                   the learned place each detected place went to (L learned / R recognised),
//                   the detected places, base point status (good white, uninformative /
//                   incoherent blue), transition regions (red) and the ground truth (labels,
//                   or the frames that revisit earlier ones); frame axis and legend.
//   pr_curve.png    recognition precision over recall for the τ_r sweep, the configured τ_r
//                   marked.
//   memory_map.png  the place memory tree and the topological map (tools/inspect's ToDot,
//                   rendered by Graphviz's `dot`).
//   floor_plan.png  only when the dataset has poses: the trajectory, each learned place at
//                   the mean pose of its frames and the map's edges.

#include <filesystem>
#include <opencv2/core.hpp>
#include <vector>

#include "tools/dataset.h"
#include "tools/eval.h"

namespace tsc {

cv::Mat DrawTimeline(const EvalResult& result);
cv::Mat DrawPrCurve(const EvalResult& result);
/// Empty when the dataset has no poses.
cv::Mat DrawFloorPlan(const EvalResult& result, const Dataset& dataset);

/// Writes the pictures above into `dir` (created when missing) and returns their paths.
/// Throws std::runtime_error naming the file that could not be written, InspectError when
/// Graphviz's `dot` is missing or fails.
std::vector<std::filesystem::path> WritePlots(const EvalResult& result, const Dataset& dataset,
                                              const std::filesystem::path& dir);

}  // namespace tsc

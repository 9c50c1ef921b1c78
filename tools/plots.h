#pragma once
// Pictures of an evaluation (`tsc eval --plots DIR`), drawn with OpenCV on a white
// background:
//   timeline.png    detection timeline (thesis figure 3.3a): one column per frame; rows for
//                   the learned place each detected place went to (L learned / R recognised),
//                   the detected places, base point status (good white, uninformative /
//                   incoherent blue), transition regions (red) and the ground truth (labels,
//                   or the frames that revisit earlier ones); frame axis and legend.
//   pr_curve.png    precision over recall for the τ_r sweep, the configured τ_r ringed:
//                   place-level recognition, with poses the view-overlap recall, and
//                   frame-level loop closures (DESIGN §7.1b).
//   memory_map.png  the place memory tree and the topological map (tools/inspect's ToDot,
//                   rendered by Graphviz's `dot`).
//   floor_plan.png  only when the dataset has poses: the trajectory, each learned place at
//                   the mean pose of its frames and the map's edges; over the simulator's
//                   floor plan (walls, doors, boxes, room labels, scale bar in metres) when
//                   DATASET/world.json exists (drivers/world/world.h, World::ToJson).

#include <filesystem>
#include <opencv2/core.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "core/classify/classification_score.h"
#include "drivers/dataset/dataset.h"
#include "tools/eval.h"

namespace tsc {

/// What the floor-plan plot needs of a world.json (drivers/world/world.h, World::ToJson):
/// metres, x east, y north.
struct WorldPlan {
  struct Rect {
    double x0 = 0.0, y0 = 0.0, x1 = 0.0, y1 = 0.0;
  };
  struct Room {
    std::string label;
    Rect rect;
    bool outdoor = false;
    std::vector<Rect> boxes;
  };
  std::string kind;         ///< "office", "corridors", "outdoor"
  std::vector<Room> rooms;  ///< at least one
  std::vector<Rect> walls;  ///< segments (x0, y0) - (x1, y1)
  std::vector<Rect> doors;  ///< the gap segments
};

/// Parses the text of a world.json with a small JSON reader limited to plain JSON (objects,
/// arrays, strings, numbers, true/false/null). Throws std::runtime_error starting with `file`
/// and saying what is wrong (bad JSON with its byte offset, a missing or mistyped field).
WorldPlan ParseWorldPlan(const std::string& text, const std::filesystem::path& file);

/// Reads `file`: nullopt when it does not exist; when it cannot be read or parsed, writes a
/// warning naming it to `warnings` and returns nullopt.
std::optional<WorldPlan> ReadWorldPlan(const std::filesystem::path& file, std::ostream& warnings);

cv::Mat DrawTimeline(const EvalResult& result);
cv::Mat DrawPrCurve(const EvalResult& result);
/// Empty when the dataset has no poses. With `world`, the walls, doors, boxes and room labels
/// are drawn under the trajectory and the places.
cv::Mat DrawFloorPlan(const EvalResult& result, const Dataset& dataset,
                      const WorldPlan* world = nullptr);

/// What a team map shows (`tsc team`, issue 21): one final memory's places and map over the
/// simulated floor plan.
struct TeamMapPicture {
  std::string title;     ///< first line
  std::string subtitle;  ///< second line
  struct Robot {
    uint32_t id = 0;
    std::vector<std::pair<double, double>> trajectory;  ///< metres, x east, y north
  };
  std::vector<Robot> robots;
  struct Place {
    PlaceId id;
    std::vector<PlaceId> sources;  ///< ids it absorbed (merged place when not empty)
    double x = 0.0, y = 0.0;       ///< mean position of the frames of all its ids
    bool located = false;          ///< false: no frame of it is known (not drawn)
    std::string label;             ///< majority ground-truth label of those frames
  };
  std::vector<Place> places;
  TopologicalMap map;
};
/// The team map: each robot's trajectory in its colour (robot r: palette colour r − 1), each
/// place at its position filled with the colour of the robot whose id it carries, a merged
/// place ringed in the colours of the robots whose places it absorbed and named with all its
/// ids, the map's edges, and the floor plan with its room labels when `world` is given. Empty
/// when no place and no trajectory has a position.
cv::Mat DrawTeamMap(const TeamMapPicture& team, const WorldPlan* world);
/// Draws the team map into `png`. Throws std::runtime_error naming the file when it cannot be
/// written or there is nothing to draw.
void WriteTeamMap(const TeamMapPicture& team, const WorldPlan* world,
                  const std::filesystem::path& png);

/// A precision-recall curve over the confidence threshold τ of `tsc classify`, named for
/// the legend (a feature set or a model).
struct NamedTauCurve {
  std::string name;
  std::vector<TauPoint> points;  ///< in τ order
};
/// Precision over recall of each curve (thesis figures 2.5, 2.6), every curve in its own
/// colour with a legend, τ = 0.5 marked on each.
cv::Mat DrawTauPrCurves(const std::vector<NamedTauCurve>& curves, const std::string& title);
/// The confusion matrix of ScoreClassification (rows true place, columns decided place, last
/// column "unclassified", last row "other" when it has frames) as a grid of cells shaded by
/// the fraction of their row, with the counts.
cv::Mat DrawConfusionMatrix(const Eigen::MatrixXi& confusion,
                            const std::vector<std::string>& places, const std::string& title);

/// Writes the pictures above into `dir` (created when missing) and returns their paths. The
/// floor plan uses DATASET/world.json when it exists; a bad one is reported on `warnings`
/// (the plot is then drawn without it).
/// Throws std::runtime_error naming the file that could not be written, InspectError when
/// Graphviz's `dot` is missing or fails.
std::vector<std::filesystem::path> WritePlots(const EvalResult& result, const Dataset& dataset,
                                              const std::filesystem::path& dir,
                                              std::ostream& warnings);
std::vector<std::filesystem::path> WritePlots(const EvalResult& result, const Dataset& dataset,
                                              const std::filesystem::path& dir);  ///< std::cerr

}  // namespace tsc

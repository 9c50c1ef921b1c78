#pragma once
// The deterministic team evaluation (`tsc team --offline`, issue 21): every robot's scripted
// route through the simulated world is replayed in-process with the pipeline and options its
// tscd would use (camera.source=sim, sim.route = robot id − 1), then the robots exchange their
// memories in a fixed order through the daemon's own path (BuildSnapshot → SnapshotAssembler →
// ToPlaceMemory, MergeMemories, MergeMaps; a merge that brings nothing new is not adopted)
// until no memory changes, and the team is scored with the rules of DESIGN §7.1b. No process,
// no bus, no clock: the same settings and order give the same memories and figures.
//
// Also the scoring both `tsc team` runs share: what one robot's final memory says for merge
// scoring (TeamMemoryForScoring) and the team verdict (merge score, consistency).

#include <cstdint>
#include <map>
#include <ostream>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "core/map/topological_map.h"
#include "core/memory/place_memory.h"
#include "settings/settings.h"
#include "tools/plots.h"
#include "tools/scoring.h"

namespace tsc {

/// Place → member base points, as Store::LoadAssignments returns them (one entry per detected
/// place, in detection order).
using PlaceAssignments = std::vector<std::pair<PlaceId, std::vector<BaseIndex>>>;

/// One robot after its route and the exchange.
struct ReplayedRobot {
  uint32_t id = 0;
  PlaceMemory memory{1, PlaceMemoryOptions{}};
  TopologicalMap map;
  PlaceAssignments assignments;     ///< every detected place of its route and its place
  std::vector<std::string> labels;  ///< ground-truth label of each route frame (= base point)
  /// Ground-truth position of each route frame (metres, x east, y north).
  std::vector<std::pair<double, double>> positions;
  /// Ground-truth pose of each route frame (positions with the camera's heading, radians).
  std::vector<GroundTruthPose> poses;
  int64_t frames = 0;  ///< base points processed
  int detected_places = 0;
  int recognitions = 0;    ///< detected places recognised (final decisions)
  int learned = 0;         ///< detected places learned as new places
  int64_t absorbed = 0;    ///< absorptions of merges it adopted ("merged" events of a live run)
  int merges_adopted = 0;  ///< merges that changed its memory or map
};

/// Replays robot `robot`'s route (1-based; its route is robot − 1) with `settings` (the
/// settings its tscd reads: camera.source must be sim). Frames come as fast as they render,
/// whatever camera.fps says; pan sweeps are taken whole as the daemon's queue hands them over.
/// Throws std::invalid_argument on settings that are not a simulated camera, and what the
/// camera or the pipeline throws.
ReplayedRobot ReplayRoute(const Settings& settings, uint32_t robot);

/// One merge of the exchange: `ours` merges `peer`'s current memory and map as the daemon
/// receives them (BuildSnapshot → SnapshotAssembler → ToPlaceMemory / ToTopologicalMap;
/// MergeMemories, MergeMaps) and adopts the result unless it brings nothing new (no place,
/// absorption or edge). Returns whether it adopted it.
bool MergePeer(ReplayedRobot& ours, const ReplayedRobot& peer, int portion_bytes);

/// The exchange: rounds in which each robot of `order` (robot ids, a permutation of the
/// team's) merges, in `order`, the current memory of every other robot, received as the
/// daemon receives it; until a round changes nothing (then returns true) or `max_rounds`
/// rounds have passed (false). Throws std::invalid_argument when `order` is not a permutation
/// of the robots' ids.
bool ExchangeMemories(std::vector<ReplayedRobot>& robots, const std::vector<uint32_t>& order,
                      int portion_bytes, int max_rounds = 20);

/// The team's routes replayed together, exchanging while they drive as live robots do: every
/// robot processes `exchange_every` base points, then each robot of `order` merges (MergePeer)
/// every other robot's memory as it stands and its pipeline goes on with the merge it adopted;
/// until every route has ended. `tsc team --offline` then settles the exchange
/// (ExchangeMemories). Robot i + 1 drives with `settings[i]`. Throws std::invalid_argument on
/// `exchange_every` < 1 or an `order` that is not a permutation of 1..N, and what ReplayRoute
/// throws.
std::vector<ReplayedRobot> ReplayTeam(const std::vector<Settings>& settings,
                                      const std::vector<uint32_t>& order, int64_t exchange_every,
                                      int portion_bytes);

/// What robot `route.id`'s final memory says for merge scoring: its own places labelled from
/// the frames of the detected places assigned to them (`route.assignments`, base point k =
/// frame k of `route.labels`) with those frames' poses, peer places its pipeline recognised,
/// and the groups (each place of `memory` with the sources it absorbed).
TeamMemoryForScoring ForMergeScoring(const ReplayedRobot& route, const PlaceMemory& memory);

/// The team's verdict: the merge score, the places each robot knows (own, taken or absorbed),
/// whether they all know the same ones, and the places per label of each final memory.
struct TeamVerdict {
  MergeScore merge;
  std::vector<std::set<PlaceId>> known;
  bool consistent = true;
  std::vector<double> places_per_label;  ///< per robot, in the order given
};
TeamVerdict JudgeTeam(const std::vector<TeamMemoryForScoring>& robots);

/// The "merge" object and what follows it in summary.json (without the closing brace):
/// `,"merge":{...},"consistent":..,"known_places":[..],"places_per_label":[..]`.
std::string TeamVerdictJson(const TeamVerdict& verdict);

/// The robots' routes as ReplayRoute records them (labels, positions) without replaying them,
/// for a live run whose memories come from the stores: the route of robot i + 1 from
/// `settings[i]`. Throws what SimCamera throws.
std::vector<ReplayedRobot> RoutesOf(const std::vector<Settings>& settings);

/// The team map of one final memory (tools/plots.h): each place at the mean position of the
/// frames of all its ids (own and absorbed) in the routes of the robots that learned them
/// (`robots`: their assignments and positions), with their majority label; every robot's
/// trajectory; the map's edges.
TeamMapPicture TeamMapOf(const PlaceMemory& memory, const TopologicalMap& map,
                         const std::vector<ReplayedRobot>& robots, std::string title,
                         std::string subtitle);
/// The floor plan of the simulated world of `settings` (sim.*).
WorldPlan WorldPlanOf(const Settings& settings);

/// Prints the verdict for people (merges, place recall, consistency, places per label).
void PrintTeamVerdict(std::ostream& out, const TeamVerdict& verdict);

}  // namespace tsc

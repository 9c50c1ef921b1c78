#include "tools/team_replay.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <ostream>
#include <sstream>
#include <stdexcept>

#include "core/merge/merge.h"
#include "core/merge/merge_maps.h"
#include "core/pipeline/pipeline.h"
#include "daemon/memory_snapshot.h"
#include "daemon/snapshot_assembler.h"
#include "drivers/camera/make_camera.h"
#include "drivers/camera/sim_camera.h"
#include "drivers/dataset/base_point_picker.h"
#include "drivers/dataset/base_point_spacing.h"
#include "drivers/dataset/lens_response.h"
#include "tools/events_json.h"

namespace tsc {
namespace {

// A figure for people: three significant digits.
std::string Figure(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

// A recall for people: "-" when there was nothing to recall (null in the JSON).
std::string RecallFigure(double v) { return std::isfinite(v) ? Figure(v) : "-"; }

// What the route did, from the pipeline's results alone (as the store records it): each
// decided detected place and its place, and the counts of the announces.
class RouteRecorder {
 public:
  explicit RouteRecorder(ReplayedRobot& robot) : robot_(robot) {}
  void Consume(const FrameResult& r) {
    if (r.has_base) ++robot_.frames;
    for (const DetectedPlace& d : r.closed_places) closed_.emplace(d.index, d.members);
    for (const PlaceEvent& e : r.events) {
      if (e.kind == EventKind::kDetected) ++robot_.detected_places;
      if (e.kind == EventKind::kAmbiguous) closed_.erase(e.detected_place);  // no place
      const bool recognized = e.kind == EventKind::kRecognized && !e.partial;
      if (!recognized && e.kind != EventKind::kLearned) continue;
      const auto it = closed_.find(e.detected_place);
      if (it == closed_.end() || !e.place) {
        throw std::logic_error("team replay: decision on detected place " +
                               std::to_string(e.detected_place) + " before it closed");
      }
      robot_.assignments.emplace_back(*e.place, it->second);
      ++(recognized ? robot_.recognitions : robot_.learned);
      closed_.erase(it);
    }
  }

 private:
  ReplayedRobot& robot_;
  std::map<DetectedPlaceIndex, std::vector<BaseIndex>> closed_;  // closed, not yet decided
};

// `memory` and `map` of robot `robot` as a peer receives them: cut into portions
// (BuildSnapshot), assembled and checked (SnapshotAssembler), rebuilt (ToPlaceMemory).
std::pair<PlaceMemory, TopologicalMap> AsReceived(const PlaceMemory& memory,
                                                  const TopologicalMap& map, uint32_t robot,
                                                  int64_t version, int portion_bytes,
                                                  const PlaceMemoryOptions& options) {
  SnapshotHeader header;
  header.robot = static_cast<int32_t>(robot);
  header.boot_id = 1;
  header.version = version;
  const MemorySnapshot snapshot = BuildSnapshot(memory, map, header, portion_bytes);
  SnapshotAssembler assembler(static_cast<int32_t>(robot));
  for (const memory_portion_v2_t& p : AllPortions(snapshot)) {
    const SnapshotAssembler::Result r = assembler.Accept(p);
    if (r.verdict != SnapshotAssembler::Verdict::kAccepted) {
      throw std::logic_error("team replay: portion of robot " + std::to_string(robot) +
                             " refused: " + r.reason);
    }
  }
  std::string reason;
  const std::optional<PeerSnapshot> peer = assembler.Take(&reason);
  if (!peer) {
    throw std::logic_error("team replay: snapshot of robot " + std::to_string(robot) +
                           " refused: " + reason);
  }
  return {ToPlaceMemory(*peer, options), ToTopologicalMap(*peer)};
}

// How far apart the simulated camera's frames lie, as the daemon resolves it
// (pipeline_worker.cc): camera.spacing_m when set, else what the route declares.
BasePointSpacing FramesOf(const Settings& settings, const SimCamera& camera) {
  const std::optional<BasePointSpacing> declared = camera.spacing();
  return ResolveSpacing(settings.daemon.camera.spacing_m, declared ? &*declared : nullptr,
                        settings.daemon.camera.fps);
}

// The route's ground truth: label and pose of every base point, the route frames the daemon's
// camera thread takes (the simulated camera renders one route frame per base point and reports
// its pose: FramesOfRoute).
void RecordRoute(const SimCamera& camera, int stride, ReplayedRobot& out) {
  std::vector<std::optional<PlanarPose>> poses;
  for (const sim::RouteFrame& f : camera.route()) {
    poses.emplace_back(PlanarPose{f.pose.x, f.pose.y, f.pose.heading});
  }
  for (const int i : FramesOfRoute(poses, stride)) {
    const sim::RouteFrame& f = camera.route()[static_cast<size_t>(i)];
    out.labels.push_back(f.label);
    out.positions.emplace_back(f.pose.x, f.pose.y);
    out.poses.push_back(GroundTruthPose{f.pose.x, f.pose.y, f.pose.heading});
  }
}

// One robot's route replayed a stretch at a time, so that a team can exchange memories while
// its robots drive (ReplayTeam), as live robots do.
class RouteReplay {
 public:
  RouteReplay(const Settings& settings, uint32_t robot)
      : camera_(CameraOptionsOf(settings)),
        base_points_(BasePointsOf(FramesOf(settings, camera_))),
        taken_(base_points_.stride),
        pipeline_(PipelineOf(settings, robot)),
        recorder_(out_) {
    out_.id = robot;
    RecordRoute(camera_, base_points_.stride, out_);
  }
  // The recorder holds a reference to out_: neither copied nor moved.
  RouteReplay(const RouteReplay&) = delete;
  RouteReplay& operator=(const RouteReplay&) = delete;
  RouteReplay(RouteReplay&&) = delete;
  RouteReplay& operator=(RouteReplay&&) = delete;
  ~RouteReplay() = default;

  /// Processes up to `count` base points, then robot() holds the memory and map as they stand;
  /// false once the route has ended (then finished).
  bool Advance(int64_t count) {
    for (int64_t done = 0; !ended_ && done < count;) {
      std::optional<CameraFrame> frame = camera_.Next();
      if (!frame) {
        recorder_.Consume(pipeline_.Finish());
        ended_ = true;
        break;
      }
      if (!taken_.Take(frame->ends_base_point, ViewMotion{frame->pose, std::nullopt, 0})) continue;
      sweep_.push_back(std::move(frame->observation));
      if (!frame->ends_base_point) continue;
      recorder_.Consume(pipeline_.Process(sweep_));
      sweep_.clear();
      ++done;
    }
    out_.memory = pipeline_.memory();
    out_.map = pipeline_.map();
    return !ended_;
  }

  /// The robot as a peer would receive it: its memory and map as of the last Advance or merge.
  ReplayedRobot& robot() { return out_; }
  /// After MergePeer adopted a merge into robot(): the pipeline goes on with it (as tscd's
  /// worker adopts a merge between base points).
  void AdoptMerged() { pipeline_.AdoptMerged(out_.memory, out_.map); }

 private:
  static SimCameraOptions CameraOptionsOf(const Settings& settings) {
    if (settings.daemon.camera.source != "sim") {
      throw std::invalid_argument("team replay: camera.source is " + settings.daemon.camera.source +
                                  ", not sim");
    }
    SimCameraOptions options =
        ToSimCameraOptions(settings.daemon.camera, settings.daemon.sim, false);
    options.fps = 0.0;  // as fast as they render: nothing is dropped, nothing waits
    options.loop = false;
    return options;
  }
  // The daemon's pipeline (daemon.cc, pipeline_worker.cc): its options, robot id, and the
  // spacing its camera declares, with the base points its camera thread takes.
  Pipeline PipelineOf(const Settings& settings, uint32_t robot) const {
    PipelineOptions options = settings.pipeline;
    options.robot = robot;
    AdaptToSpacing(options, base_points_.spacing);
    AdaptToLens(options, CameraLens::Of(camera_.intrinsics(), camera_.views_per_base_point()));
    return Pipeline(camera_.intrinsics(), options, PlaceMemory(robot, options.memory),
                    TopologicalMap{});
  }

  SimCamera camera_;
  BasePoints base_points_;
  BasePointPicker taken_;
  Pipeline pipeline_;
  ReplayedRobot out_;
  RouteRecorder recorder_;
  std::vector<Observation> sweep_;
  bool ended_ = false;
};

}  // namespace

ReplayedRobot ReplayRoute(const Settings& settings, uint32_t robot) {
  RouteReplay replay(settings, robot);
  while (replay.Advance(std::numeric_limits<int64_t>::max())) {
  }
  return std::move(replay.robot());
}

bool MergePeer(ReplayedRobot& ours, const ReplayedRobot& peer, int portion_bytes) {
  auto [peer_memory, peer_map] = AsReceived(peer.memory, peer.map, peer.id, 1 + peer.merges_adopted,
                                            portion_bytes, ours.memory.options());
  MemoryMerge merged = MergeMemories(ours.memory, peer_memory);
  TopologicalMap map = MergeMaps(ours.map, peer_map, merged.memory);
  if (!MergeChangesAnything(merged, map, ours.map)) return false;  // as the daemon
  ours.absorbed += static_cast<int64_t>(merged.absorbed.size());
  ++ours.merges_adopted;
  ours.memory = std::move(merged.memory);
  ours.map = std::move(map);
  return true;
}

namespace {

// Robot id → its position in `ids`; throws when `order` is not a permutation of them.
std::map<uint32_t, size_t> IndexInOrder(const std::vector<uint32_t>& ids,
                                        const std::vector<uint32_t>& order) {
  std::map<uint32_t, size_t> index;
  for (size_t i = 0; i < ids.size(); ++i) index[ids[i]] = i;
  std::vector<uint32_t> sorted = order, known;
  std::sort(sorted.begin(), sorted.end());
  for (const auto& [id, i] : index) known.push_back(id);
  if (sorted != known || index.size() != ids.size()) {
    throw std::invalid_argument("the merge order must name every robot of the team once");
  }
  return index;
}

}  // namespace

bool ExchangeMemories(std::vector<ReplayedRobot>& robots, const std::vector<uint32_t>& order,
                      int portion_bytes, int max_rounds) {
  std::vector<uint32_t> ids;
  ids.reserve(robots.size());
  for (const ReplayedRobot& r : robots) ids.push_back(r.id);
  std::map<uint32_t, size_t> index = IndexInOrder(ids, order);
  for (int round = 0; round < max_rounds; ++round) {
    bool changed = false;
    for (uint32_t r : order) {
      for (uint32_t s : order) {
        if (s != r) changed |= MergePeer(robots[index[r]], robots[index[s]], portion_bytes);
      }
    }
    if (!changed) return true;
  }
  return false;
}

std::vector<ReplayedRobot> ReplayTeam(const std::vector<Settings>& settings,
                                      const std::vector<uint32_t>& order, int64_t exchange_every,
                                      int portion_bytes) {
  if (exchange_every < 1) throw std::invalid_argument("exchange_every must be at least 1");
  std::vector<std::unique_ptr<RouteReplay>> replays;
  std::vector<uint32_t> ids;
  for (size_t i = 0; i < settings.size(); ++i) {
    ids.push_back(static_cast<uint32_t>(i + 1));
    replays.push_back(std::make_unique<RouteReplay>(settings[i], ids.back()));
  }
  std::map<uint32_t, size_t> index = IndexInOrder(ids, order);
  for (bool driving = true; driving;) {
    driving = false;
    for (auto& r : replays) driving |= r->Advance(exchange_every);
    for (uint32_t r : order) {  // one round, each merging the others as they stand now
      for (uint32_t s : order) {
        if (s == r) continue;
        RouteReplay& ours = *replays[index[r]];
        if (MergePeer(ours.robot(), replays[index[s]]->robot(), portion_bytes)) ours.AdoptMerged();
      }
    }
  }
  std::vector<ReplayedRobot> robots;
  robots.reserve(replays.size());
  for (auto& r : replays) robots.push_back(std::move(r->robot()));
  return robots;
}

TeamMemoryForScoring ForMergeScoring(const ReplayedRobot& route, const PlaceMemory& memory) {
  const uint32_t robot = route.id;
  const PlaceAssignments& assignments = route.assignments;
  const std::vector<std::string>& labels = route.labels;
  GroundTruth truth;
  truth.labels = labels;
  TeamMemoryForScoring out;
  // Labels of every place this robot learned, from the detected places it assigned to them
  // (these survive a merge that absorbed the place into a peer's).
  std::map<PlaceId, std::vector<int>> frames_of;
  for (const auto& [place, members] : assignments) {
    std::vector<int> frames;
    for (BaseIndex b : members) {
      if (b >= 0 && b < static_cast<BaseIndex>(labels.size())) {
        frames.push_back(static_cast<int>(b));
      }
    }
    if (place.robot != robot) {
      if (!frames.empty()) out.peer_recognitions.emplace_back(place, MajorityLabel(truth, frames));
      continue;
    }
    std::vector<int>& all = frames_of[place];
    all.insert(all.end(), frames.begin(), frames.end());
  }
  for (const auto& [place, frames] : frames_of) {
    out.own_labels[place] = MajorityLabel(truth, frames);
    std::vector<GroundTruthPose>& poses = out.own_poses[place];
    for (int f : frames) {
      if (f < static_cast<int>(route.poses.size()))
        poses.push_back(route.poses[static_cast<size_t>(f)]);
    }
  }
  for (const LearnedPlace& p : memory.places()) {
    std::vector<PlaceId> group = {p.id};
    group.insert(group.end(), p.sources.begin(), p.sources.end());
    out.groups.push_back(std::move(group));
  }
  return out;
}

TeamVerdict JudgeTeam(const std::vector<TeamMemoryForScoring>& robots) {
  TeamVerdict v;
  v.merge = ScoreMerges(robots);
  std::map<PlaceId, std::string> labels;
  for (const TeamMemoryForScoring& r : robots)
    labels.insert(r.own_labels.begin(), r.own_labels.end());
  // Consistent memories (chapter 4): every robot knows the same places, as places of its own
  // memory or as the sources they absorbed.
  v.known.resize(robots.size());
  for (size_t i = 0; i < robots.size(); ++i) {
    for (const std::vector<PlaceId>& g : robots[i].groups) v.known[i].insert(g.begin(), g.end());
    v.places_per_label.push_back(PlacesPerLabel(robots[i].groups, labels));
  }
  for (const std::set<PlaceId>& k : v.known) v.consistent &= k == v.known.front();
  return v;
}

std::string TeamVerdictJson(const TeamVerdict& v) {
  const MergeScore& merge = v.merge;
  std::ostringstream json;
  json << ",\"merge\":{\"merges\":" << merge.merges << ",\"correct\":" << merge.correct
       << ",\"same_label_pairs\":" << merge.same_label_pairs
       << ",\"precision\":" << JsonNumber(merge.precision)
       << ",\"recall\":" << JsonNumber(merge.recall)
       << ",\"pair_recall\":" << JsonNumber(merge.recall)
       << ",\"places_with_namesake\":" << merge.places_with_namesake
       << ",\"places_merged_with_namesake\":" << merge.places_merged_with_namesake
       << ",\"place_recall\":" << JsonNumber(merge.place_recall)
       << ",\"view_places_with_namesake\":" << merge.view_places_with_namesake
       << ",\"view_places_merged_with_namesake\":" << merge.view_places_merged_with_namesake
       << ",\"view_place_recall\":" << JsonNumber(merge.view_place_recall)
       << ",\"peer_recognitions\":" << merge.peer_recognitions
       << ",\"peer_recognitions_correct\":" << merge.peer_recognitions_correct
       << ",\"wrong_peer_recognitions\":[";
  for (size_t i = 0; i < merge.wrong_peer_recognitions.size(); ++i) {
    const MergeScore::WrongPeerRecognition& w = merge.wrong_peer_recognitions[i];
    json << (i ? "," : "") << "{\"place\":" << JsonString(w.place.ToString())
         << ",\"place_label\":" << JsonString(w.place_label)
         << ",\"frames_label\":" << JsonString(w.frames_label) << "}";
  }
  json << "]}";
  json << ",\"consistent\":" << (v.consistent ? "true" : "false") << ",\"known_places\":[";
  for (size_t i = 0; i < v.known.size(); ++i) json << (i ? "," : "") << v.known[i].size();
  json << "],\"places_per_label\":[";
  for (size_t i = 0; i < v.places_per_label.size(); ++i) {
    json << (i ? "," : "") << JsonNumber(v.places_per_label[i]);
  }
  json << "]";
  return json.str();
}

std::vector<ReplayedRobot> RoutesOf(const std::vector<Settings>& settings) {
  std::vector<ReplayedRobot> out;
  for (size_t i = 0; i < settings.size(); ++i) {
    const SimCamera route(ToSimCameraOptions(settings[i].daemon.camera, settings[i].daemon.sim));
    ReplayedRobot r;
    r.id = static_cast<uint32_t>(i + 1);
    RecordRoute(route, StrideFor(FramesOf(settings[i], route)), r);
    out.push_back(std::move(r));
  }
  return out;
}

TeamMapPicture TeamMapOf(const PlaceMemory& memory, const TopologicalMap& map,
                         const std::vector<ReplayedRobot>& robots, std::string title,
                         std::string subtitle) {
  TeamMapPicture out;
  out.title = std::move(title);
  out.subtitle = std::move(subtitle);
  out.map = map;
  // Every robot's frames of each of its own places.
  std::map<PlaceId, std::vector<std::pair<const ReplayedRobot*, BaseIndex>>> frames_of;
  for (const ReplayedRobot& r : robots) {
    out.robots.push_back({r.id, r.positions});
    for (const auto& [place, members] : r.assignments) {
      if (place.robot != r.id) continue;
      for (BaseIndex b : members) {
        if (b >= 0 && b < static_cast<BaseIndex>(r.positions.size())) {
          frames_of[place].emplace_back(&r, b);
        }
      }
    }
  }
  for (const LearnedPlace& p : memory.places()) {
    TeamMapPicture::Place place;
    place.id = p.id;
    place.sources = p.sources;
    double sx = 0, sy = 0;
    int n = 0;
    std::map<std::string, int> votes;
    std::vector<PlaceId> ids = {p.id};
    ids.insert(ids.end(), p.sources.begin(), p.sources.end());
    for (const PlaceId& id : ids) {
      const auto it = frames_of.find(id);
      if (it == frames_of.end()) continue;
      for (const auto& [robot, b] : it->second) {
        const auto& [x, y] = robot->positions[static_cast<size_t>(b)];
        sx += x, sy += y, ++n;
        const std::string& l = robot->labels[static_cast<size_t>(b)];
        if (!l.empty()) ++votes[l];
      }
    }
    if (n > 0) {
      place.located = true;
      place.x = sx / n;
      place.y = sy / n;
    }
    if (!votes.empty()) {
      place.label = std::max_element(votes.begin(), votes.end(), [](const auto& a, const auto& b) {
                      return a.second < b.second;
                    })->first;
    }
    out.places.push_back(std::move(place));
  }
  return out;
}

WorldPlan WorldPlanOf(const Settings& settings) {
  const SimCamera camera(ToSimCameraOptions(settings.daemon.camera, settings.daemon.sim));
  return ParseWorldPlan(camera.world().ToJson(), "simulated world");
}

void PrintTeamVerdict(std::ostream& out, const TeamVerdict& v) {
  const MergeScore& merge = v.merge;
  out << "merges (DESIGN 7.1b): " << merge.merges << " pairs merged, " << merge.correct
      << " correct, " << merge.same_label_pairs
      << " pairs of places of different robots in the same room; precision "
      << Figure(merge.precision) << ", recall " << RecallFigure(merge.recall) << "\n"
      << "places merged with a place of another robot in their room: "
      << merge.places_merged_with_namesake << " of " << merge.places_with_namesake
      << " (place recall " << RecallFigure(merge.place_recall) << ")\n";
  if (std::isfinite(merge.view_place_recall)) {
    out << "of those sharing a view with it (2 m, 45 degrees): "
        << merge.view_places_merged_with_namesake << " of " << merge.view_places_with_namesake
        << " (view place recall " << Figure(merge.view_place_recall) << ")\n";
  }
  out << "peer places recognised by the robots' pipelines: " << merge.peer_recognitions
      << " detected places, " << merge.peer_recognitions_correct << " correct\n";
  for (const MergeScore::WrongPeerRecognition& w : merge.wrong_peer_recognitions) {
    out << "  wrong: " << w.place.ToString() << " ("
        << (w.place_label.empty() ? "no label" : w.place_label) << ") recognised on frames of "
        << (w.frames_label.empty() ? "no label" : w.frames_label) << "\n";
  }
  out << "memories " << (v.consistent ? "consistent" : "NOT consistent")
      << ": places known (own, taken or absorbed) per robot:";
  for (const std::set<PlaceId>& k : v.known) out << " " << k.size();
  out << "\nplaces per label per final memory:";
  for (double p : v.places_per_label) out << " " << Figure(p);
  out << "\n";
}

}  // namespace tsc

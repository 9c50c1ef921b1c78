#include "drivers/world/world.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "core/bubble/descriptor.h"
#include "core/pipeline/pipeline.h"
#include "drivers/dataset/dataset.h"
#include "drivers/world/dataset_writer.h"
#include "drivers/world/renderer.h"
#include "drivers/world/routes.h"
#include "test/support/temp_dir.h"
#include "tools/sim_command.h"

namespace tsc::sim {
namespace {
namespace fs = std::filesystem;

RenderOptions Small() {
  RenderOptions o;
  o.width = 160;
  o.height = 120;
  return o;
}

/// Labels in visiting order, consecutive repeats and doorways ("") removed.
std::vector<std::string> Visits(const std::vector<std::string>& labels) {
  std::vector<std::string> out;
  for (const std::string& l : labels) {
    if (!l.empty() && (out.empty() || out.back() != l)) out.push_back(l);
  }
  return out;
}

std::vector<std::string> LabelsOf(const std::vector<RouteFrame>& route) {
  std::vector<std::string> out;
  for (const RouteFrame& f : route) out.push_back(f.label);
  return out;
}

class WorldTest : public ::testing::Test {
 protected:
  testing_support::TempDir temp_{"tscd_world_test"};
  fs::path dir_ = temp_.path() / "out";
};

TEST_F(WorldTest, SameSeedGivesIdenticalFramesAndOtherSeedDiffers) {
  auto frame = [](std::uint32_t seed) {
    std::mt19937 rng(seed);
    const World world = World::Generate(WorldKind::kOffice, rng);
    const Renderer dut(world, Small(), seed);
    const Room& r = world.rooms()[1];
    cv::Mat bgr;
    dut.Render(Pose2{r.cx(), r.cy(), 0.3}, &bgr, nullptr);
    dut.ApplyLighting(Lighting::Day(), rng, &bgr);
    return bgr;
  };
  const cv::Mat a = frame(5), b = frame(5), c = frame(6);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(a, c, cv::NORM_L1), 0.0);
}

TEST_F(WorldTest, SingleRobotRouteVisitsEveryRoomAndRevisitsHalf) {
  for (WorldKind kind : {WorldKind::kOffice, WorldKind::kCorridors, WorldKind::kOutdoor}) {
    std::mt19937 rng(3);
    const World world = World::Generate(kind, rng);
    const RouteOptions options;
    const auto route = FollowRooms(world, SingleRobotTargets(world, options, rng), options);
    std::map<std::string, int> visits;
    for (const std::string& l : Visits(LabelsOf(route))) ++visits[l];
    int revisited = 0;
    for (const Room& r : world.rooms()) {
      EXPECT_GE(visits[r.label], 1) << WorldKindName(kind) << " " << r.label;
      if (visits[r.label] >= 2) ++revisited;
    }
    EXPECT_GE(2 * revisited, static_cast<int>(world.rooms().size())) << WorldKindName(kind);
    // A room visit is many frames.
    EXPECT_GT(route.size(), 20 * world.rooms().size()) << WorldKindName(kind);
  }
}

// A looping camera drives its route again and again (tscd with camera.loop, tsc soak --loop):
// a closed route walks back to its first pose, so no step between frames, the one from the
// last frame to the first included, is longer than a walking step, and the tour before the
// way back is the open route's frame for frame.
TEST_F(WorldTest, ClosedRouteWalksBackToItsFirstPoseAfterTheSameTour) {
  for (WorldKind kind : {WorldKind::kOffice, WorldKind::kCorridors, WorldKind::kOutdoor}) {
    std::mt19937 rng(5);
    const World world = World::Generate(kind, rng);
    RouteOptions options;
    std::mt19937 tour_rng(6);
    const std::vector<int> targets = SingleRobotTargets(world, options, tour_rng);
    const auto open = FollowRooms(world, targets, options);
    options.closed = true;
    const auto closed = FollowRooms(world, targets, options);
    ASSERT_GT(closed.size(), open.size()) << WorldKindName(kind);
    for (size_t i = 0; i < open.size(); ++i) {
      ASSERT_EQ(closed[i].pose.x, open[i].pose.x) << WorldKindName(kind) << " frame " << i;
      ASSERT_EQ(closed[i].pose.y, open[i].pose.y) << WorldKindName(kind) << " frame " << i;
    }
    const double step = options.step_m + 1e-9;
    for (size_t i = 0; i < closed.size(); ++i) {
      const Pose2& a = closed[i].pose;
      const Pose2& b = closed[(i + 1) % closed.size()].pose;  // the lap's end joins its start
      EXPECT_LE(std::hypot(b.x - a.x, b.y - a.y), step) << WorldKindName(kind) << " frame " << i;
    }
  }
}

TEST_F(WorldTest, LabelIsEmptyExactlyInsideDoorways) {
  std::mt19937 rng(9);
  const World dut = World::Generate(WorldKind::kCorridors, rng);
  std::uniform_real_distribution<double> ux(-8.0, 32.0), uy(-8.0, 24.0);
  int in_doorway = 0;
  for (int i = 0; i < 20000; ++i) {
    const double x = ux(rng), y = uy(rng);
    const bool inside = dut.RoomAt(x, y) >= 0;
    if (!inside) continue;
    const cv::Vec4d* zone = nullptr;
    std::vector<cv::Vec4d> zones;
    for (int d = 0; d < static_cast<int>(dut.doors().size()); ++d) {
      zones.push_back(dut.DoorwayZone(d));
    }
    for (const cv::Vec4d& z : zones) {
      if (x >= z[0] && x <= z[2] && y >= z[1] && y <= z[3]) zone = &z;
    }
    EXPECT_EQ(dut.LabelAt(x, y).empty(), zone != nullptr) << x << "," << y;
    if (zone != nullptr) ++in_doorway;
  }
  EXPECT_GT(in_doorway, 0);
  // Each door's centre is a doorway, points 1 m either side are in its two rooms.
  for (const Door& d : dut.doors()) {
    EXPECT_EQ(dut.LabelAt(d.cx(), d.cy()), "");
    const double ox = d.vertical_wall ? 1.0 : 0.0, oy = d.vertical_wall ? 0.0 : 1.0;
    std::set<std::string> sides = {dut.LabelAt(d.cx() - ox, d.cy() - oy),
                                   dut.LabelAt(d.cx() + ox, d.cy() + oy)};
    EXPECT_EQ(sides, (std::set<std::string>{dut.rooms()[static_cast<size_t>(d.room_a)].label,
                                            dut.rooms()[static_cast<size_t>(d.room_b)].label}));
  }
}

TEST_F(WorldTest, DepthIsDistanceToFacedWall) {
  Room room;
  room.label = "box";
  room.x0 = 0, room.y0 = 0, room.x1 = 10, room.y1 = 8;
  const World world(WorldKind::kOffice, {room}, {});
  const Renderer dut(world, Small(), 1);
  cv::Mat bgr, depth;
  for (double d : {1.5, 3.0, 6.0}) {
    dut.Render(Pose2{10.0 - d, 4.0, 0.0}, &bgr, &depth);
    ASSERT_EQ(depth.type(), CV_32F);
    const float centre = depth.at<float>(60, 80);
    EXPECT_NEAR(centre, d, 0.03 * d);
    // Off-axis columns of a fronto-parallel wall have the same optical depth.
    EXPECT_NEAR(depth.at<float>(60, 10), d, 0.03 * d);
  }
}

TEST_F(WorldTest, DimFrameIsDarkerThanDay) {
  std::mt19937 rng(4);
  const World world = World::Generate(WorldKind::kOffice, rng);
  const Renderer dut(world, Small(), 2);
  const Room& r = world.rooms()[2];
  cv::Mat day, dim;
  dut.Render(Pose2{r.cx(), r.cy(), 1.0}, &day, nullptr);
  dim = day.clone();
  dut.ApplyLighting(Lighting::Day(), rng, &day);
  dut.ApplyLighting(Lighting::Dim(), rng, &dim);
  EXPECT_LT(cv::mean(dim)[0] + cv::mean(dim)[1] + cv::mean(dim)[2],
            0.7 * (cv::mean(day)[0] + cv::mean(day)[1] + cv::mean(day)[2]));
}

TEST_F(WorldTest, WrittenDatasetLoadsWithFramesCameraAndLabels) {
  SimOptions options;
  options.seed = 12;
  options.render = Small();
  options.depth = true;
  options.max_frames = 40;
  const SimSummary summary = WriteSimulatedDataset(dir_, options);
  ASSERT_EQ(summary.frames, std::vector<int>{40});
  const Dataset ds = Dataset::Open(dir_);
  EXPECT_EQ(ds.size(), 40);
  EXPECT_TRUE(ds.has_depth());
  EXPECT_EQ(ds.camera().width(), 160);
  EXPECT_EQ(ds.camera().height(), 120);
  EXPECT_NEAR(ds.camera().fx(), 80.0 / std::tan(29.0 * std::numbers::pi / 180.0), 0.1);
  ASSERT_EQ(ds.labels().size(), 40u);
  EXPECT_FALSE(ds.labels()[0].empty());
  ASSERT_EQ(ds.poses().size(), 40u);
  EXPECT_TRUE(ds.poses()[0].has_value());
  const Observation obs = ds.Load(0).front();
  EXPECT_EQ(obs.bgr.cols, 160);
  EXPECT_TRUE(fs::exists(dir_ / "world.json"));
  // The same seed writes the same bytes.
  const fs::path again = dir_.string() + "_again";
  fs::remove_all(again);
  WriteSimulatedDataset(again, options);
  auto bytes = [](const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  EXPECT_EQ(bytes(dir_ / "000017.jpg"), bytes(again / "000017.jpg"));
  EXPECT_EQ(bytes(dir_ / "groundtruth.csv"), bytes(again / "groundtruth.csv"));
  fs::remove_all(again);
}

TEST_F(WorldTest, PanSweepDatasetHoldsTheViewsSideBySide) {
  SimOptions options;
  options.seed = 12;
  options.render = Small();
  options.depth = true;
  options.png = true;
  options.max_frames = 3;
  options.sweep = PanSweep(4, 360.0);
  WriteSimulatedDataset(dir_, options);
  const cv::Mat strip = cv::imread((dir_ / "000002.png").string());
  ASSERT_EQ(strip.size(), cv::Size(4 * 160, 120));
  const Dataset ds = Dataset::Open(dir_);
  EXPECT_EQ(ds.camera().width(), 160);  // the intrinsics are one view's
  EXPECT_EQ(ds.sweep().views(), 4);
  const std::vector<Observation> views = ds.Load(1);
  ASSERT_EQ(views.size(), 4u);
  for (int j = 0; j < 4; ++j) {
    const Observation& v = views[static_cast<size_t>(j)];
    EXPECT_NEAR(v.pan_tilt.pan_rad, j * std::numbers::pi / 2.0, 1e-12);
    ASSERT_EQ(v.bgr.size(), cv::Size(160, 120));
    ASSERT_EQ(v.depth_m.size(), cv::Size(160, 120));
    EXPECT_EQ(cv::norm(v.bgr, strip(cv::Rect(160 * j, 0, 160, 120)), cv::NORM_L1), 0.0);
  }
  // Views look in different directions: no two are the same picture.
  EXPECT_GT(cv::norm(views[0].bgr, views[2].bgr, cv::NORM_L1), 0.0);
}

// What a sweep is for: the bubble descriptor of a full pan sweep depends little on where the
// robot faces (appendix A's pan invariance, over the whole circle), while a forward view
// changes as much as going to another room. Not exactly invariant: a turn that is not a whole
// number of pan cells (and views) samples the patches at other places and scales.
TEST_F(WorldTest, SweepDescriptorChangesLessWithTheHeadingThanAForwardViewOrAnotherRoom) {
  std::mt19937 rng(3);
  const World world = World::Generate(WorldKind::kOffice, rng);
  const Renderer renderer(world, Small(), 1);
  const Room* first_room = nullptr;
  for (const Room& r : world.rooms()) {
    if (!r.transit && first_room == nullptr) first_room = &r;
  }
  ASSERT_NE(first_room, nullptr);
  const Room& room = *first_room;
  const CameraIntrinsics camera = CameraIntrinsics::FromHorizontalFov(160, 120, Small().hfov_deg);
  const FeatureSet features = FeatureSet::Thesis(2, true);
  BubbleSurface surface(features, camera);
  const DescriptorComputer computer(surface.grid());
  const auto describe = [&](const Room& at, double heading, const PanSweep& sweep) {
    for (int j = 0; j < sweep.views(); ++j) {
      Observation obs;
      renderer.Render(Pose2{at.cx(), at.cy(), heading + sweep.View(j).pan_rad}, &obs.bgr, nullptr);
      obs.pan_tilt = sweep.View(j);
      surface.Observe(obs);
    }
    return FinishBasePoint(surface, computer).descriptor.values();
  };
  const PanSweep sweep(6, 360.0), forward;
  const double quarter = 0.5 * std::numbers::pi;
  // Turned by a quarter: a shift of 36 pan cells, not a whole number of views, so parts of
  // the room fall on the views' edges, where a patch is sampled at another scale.
  const Eigen::VectorXf here = describe(room, 0.0, sweep);
  const double sweep_turn = ChiSquared(here, describe(room, quarter, sweep));
  const double view_turn =
      ChiSquared(describe(room, 0.0, forward), describe(room, quarter, forward));
  double other_room = std::numeric_limits<double>::infinity();  // the nearest other room
  for (const Room& r : world.rooms()) {
    if (r.label == room.label || r.transit) continue;
    other_room = std::min(other_room, ChiSquared(here, describe(r, 0.0, sweep)));
  }
  std::printf(
      "χ² after a quarter turn: sweep %.4f, forward view %.4f; sweep to another room %.4f\n",
      sweep_turn, view_turn, other_room);
  EXPECT_LT(sweep_turn, 0.6 * view_turn);
  EXPECT_LT(sweep_turn, 0.5 * other_room);
}

// A slower camera on the same route (SimOptions::frame_every): every N-th route frame, at
// the same poses, and camera.json declares base points N route steps apart.
TEST_F(WorldTest, SlowerCameraTakesEveryNthFrameOfTheSameRoute) {
  SimOptions options;
  options.seed = 12;
  options.render.width = 64;
  options.render.height = 48;
  options.max_frames = 30;
  WriteSimulatedDataset(dir_, options);
  const fs::path slow = dir_.string() + "_every3";
  fs::remove_all(slow);
  options.frame_every = 3;
  options.max_frames = 10;
  const SimSummary summary = WriteSimulatedDataset(slow, options);
  ASSERT_EQ(summary.frames, std::vector<int>{10});
  const Dataset all = Dataset::Open(dir_), every3 = Dataset::Open(slow);
  EXPECT_NEAR(all.spacing().metres, 0.15, 1e-9);
  EXPECT_NEAR(every3.spacing().metres, 0.45, 1e-9);
  EXPECT_FALSE(every3.spacing().keyframes);
  ASSERT_EQ(every3.size(), 10);
  for (int i = 0; i < every3.size(); ++i) {
    const auto& p = every3.poses()[static_cast<size_t>(i)];
    const auto& q = all.poses()[static_cast<size_t>(3 * i)];
    ASSERT_TRUE(p && q);
    // The route's pose; the camera's noise is drawn per frame taken.
    EXPECT_NEAR(p->x, q->x, 0.2) << i;
    EXPECT_NEAR(p->y, q->y, 0.2) << i;
    EXPECT_EQ(every3.labels()[static_cast<size_t>(i)], all.labels()[static_cast<size_t>(3 * i)]);
  }
  fs::remove_all(slow);
  options.frame_every = 0;
  EXPECT_THROW(WriteSimulatedDataset(slow, options), std::invalid_argument);
}

TEST_F(WorldTest, MixedLightingDimsRevisits) {
  SimOptions options;
  options.seed = 8;
  options.render.width = 64;
  options.render.height = 48;
  options.route.dwell_frames = 4;
  options.lighting = LightingMode::kMixed;
  options.glitch_probability = 0.0;
  WriteSimulatedDataset(dir_, options);
  const Dataset ds = Dataset::Open(dir_);
  // First visits against revisits, by the ground-truth labels.
  std::set<std::string> done;
  std::string current;
  double sum[2] = {0, 0};
  int count[2] = {0, 0};
  for (int i = 0; i < ds.size(); ++i) {
    const std::string& l = ds.labels()[static_cast<size_t>(i)];
    if (l.empty()) continue;
    if (l != current) {
      if (!current.empty()) done.insert(current);
      current = l;
    }
    const int revisit = done.count(l) ? 1 : 0;
    const cv::Scalar m = cv::mean(ds.Load(i).front().bgr);
    sum[revisit] += m[0] + m[1] + m[2];
    ++count[revisit];
  }
  ASSERT_GT(count[0], 0);
  ASSERT_GT(count[1], 0);
  EXPECT_LT(sum[1] / count[1], 0.7 * sum[0] / count[0]);
}

TEST_F(WorldTest, TeamRoutesShareARoom) {
  std::mt19937 rng(21);
  const World world = World::Generate(WorldKind::kOffice, rng);
  RouteOptions options;
  const auto targets = TeamTargets(world, 3, options, rng);
  ASSERT_EQ(targets.size(), 3u);
  std::vector<std::set<std::string>> labels;
  for (const auto& t : targets) {
    const auto route = FollowRooms(world, t, options);
    std::set<std::string> s;
    for (const RouteFrame& f : route) {
      if (!f.label.empty() && f.label != "corridor") s.insert(f.label);
    }
    labels.push_back(s);
  }
  std::set<std::string> common = labels[0];
  for (const auto& s : labels) {
    std::set<std::string> next;
    for (const std::string& l : s) {
      if (common.count(l)) next.insert(l);
    }
    common = next;
  }
  EXPECT_FALSE(common.empty());
  EXPECT_NE(labels[0], labels[1]);  // partly different
}

TEST_F(WorldTest, SlowerTurnsSpreadTheSameRouteOverMoreFrames) {
  std::mt19937 rng(3);
  const World world = World::Generate(WorldKind::kOffice, rng);
  RouteOptions fast;
  RouteOptions slow;
  slow.turn_step_deg = 5.0;
  const std::vector<int> targets = SingleRobotTargets(world, fast, rng);
  const auto a = FollowRooms(world, targets, fast);
  const auto b = FollowRooms(world, targets, slow);
  EXPECT_GT(b.size(), a.size());
  // Consecutive headings never differ by more than the turn step (plus walking turns of 0).
  for (size_t i = 1; i < b.size(); ++i) {
    const double d = std::remainder(b[i].pose.heading - b[i - 1].pose.heading, 2 * M_PI);
    EXPECT_LE(std::abs(d), 5.0 * M_PI / 180.0 + 1e-9) << "frame " << i;
  }
}

TEST_F(WorldTest, SimCommandWritesTeamFolders) {
  const int rc =
      RunSimCommand({"--out", dir_.string(), "--seed", "4", "--robots", "2", "--size", "96x72",
                     "--hfov", "90", "--max-frames", "15", "--world", "outdoor"});
  ASSERT_EQ(rc, 0);
  for (const char* id : {"1", "2"}) {
    const Dataset ds = Dataset::Open(dir_ / "robots" / id);
    EXPECT_EQ(ds.size(), 15);
    EXPECT_EQ(ds.camera().width(), 96);
    EXPECT_NEAR(ds.camera().fx(), 48.0, 1e-6);  // 90°: the focal length is half the width
  }
  EXPECT_TRUE(fs::exists(dir_ / "world.json"));
  // Not empty any more: a runtime failure.
  EXPECT_EQ(RunSimCommand({"--out", dir_.string(), "--seed", "4"}), 1);
}

TEST_F(WorldTest, SimCommandRejectsBadUsage) {
  EXPECT_EQ(RunSimCommand({"--seed", "4"}), 2);  // no --out
  EXPECT_EQ(RunSimCommand({"--out", dir_.string(), "--seed", "4", "--world", "moon"}), 2);
  EXPECT_EQ(RunSimCommand({"--out", dir_.string(), "--seed", "4", "--size", "big"}), 2);
  EXPECT_EQ(RunSimCommand({"--out", dir_.string(), "--seed", "4", "--lighting", "x"}), 2);
  EXPECT_EQ(RunSimCommand({"--out", dir_.string(), "--seed", "4", "--revisit-fraction", "2"}), 2);
  EXPECT_EQ(RunSimCommand({"--out", dir_.string(), "--seed", "-1"}), 2);
  EXPECT_EQ(RunSimCommand({"--out", dir_.string(), "--seed", "4", "--robots", "0"}), 2);
  EXPECT_EQ(RunSimCommand({"--out", dir_.string(), "--seed", "4", "--hfov", "180"}), 2);
  EXPECT_EQ(RunSimCommand({"--help"}), 0);
  EXPECT_FALSE(fs::exists(dir_));
}

}  // namespace
}  // namespace tsc::sim

#pragma once
// The simulated world as a live camera: frames rendered at a frame rate from either this
// robot's scripted route (the same world and routes `tsc sim` writes for the seed) or the
// pose of a base (normally a SimBase driven by teleop or a planner).

#include <deque>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "drivers/base/motor_base.h"
#include "drivers/camera/camera_source.h"
#include "drivers/clock.h"
#include "drivers/world/renderer.h"
#include "drivers/world/routes.h"
#include "drivers/world/scenario.h"
#include "drivers/world/sim_options.h"
#include "drivers/world/world.h"

namespace tsc {

struct SimCameraOptions {
  /// World kind, seed, team size (scene.robots), lighting (day | dim | flicker | mixed: first
  /// visits by day, revisits dim), depth, frame size and field of view (scene.render), route
  /// shape (scene.route), camera jitter and glitches, and scene.max_frames (0 = whole route).
  /// scene.png is ignored.
  sim::SimOptions scene;
  int robot = 0;      ///< this robot's route, in [0, scene.robots)
  double fps = 10.0;  ///< frames per second delivered; 0 = as fast as they render
  /// Scripted route: start again at its first pose after the last, the route closed
  /// (RouteOptions::closed) so that a lap ends where the next begins.
  bool loop = false;
  /// Scripted route: the first frame delivered, modulo the route's length (cut to
  /// scene.max_frames): a robot started again where it stood.
  int64_t start_frame = 0;
  /// Throws std::invalid_argument naming the bad field.
  void Validate() const;
};

/// The scene a camera of `options` renders: options.scene, its route closed when looping.
sim::SimOptions SceneOf(const SimCameraOptions& options);

class SimCamera : public CameraSource {
 public:
  /// Follows this robot's scripted route, one route frame per Next(). Frames are
  /// deterministic given the options; with one robot they are the frames `tsc sim --png`
  /// writes for the same options. Throws std::invalid_argument for bad options.
  explicit SimCamera(const SimCameraOptions& options, Clock& clock = Clock::System());
  /// Renders from base.state() (x, y, heading in the world frame; start the base at
  /// start_pose()). Never ends. `base` and `clock` must outlive the camera.
  SimCamera(const SimCameraOptions& options, const MotorBase& base, Clock& clock = Clock::System());
  SimCamera(const SimCamera&) = delete;
  SimCamera& operator=(const SimCamera&) = delete;

  /// The next rendered frame (with depth_m when scene.depth), at most fps per second; with a
  /// pan sweep (scene.sweep) the views of one pose, the last one ending the base point.
  /// Scripted route: nullopt after its last frame unless looping.
  std::optional<CameraFrame> Next() override;
  bool replays_every_frame() const override { return options_.fps == 0.0; }
  const CameraIntrinsics& intrinsics() const override { return intrinsics_; }
  int views_per_base_point() const override { return options_.scene.sweep.views(); }
  /// "sim:office/7/route 2" or "sim:office/7/base".
  std::string name() const override;
  /// Scripted route: its walking step, one route frame per base point whatever the frame rate
  /// (as `tsc sim` declares it). Driven by a base: nullopt, the spacing follows the rate.
  std::optional<BasePointSpacing> spacing() const override {
    if (base_ != nullptr) return std::nullopt;
    return BasePointSpacing{options_.scene.route.step_m, "simulated route step"};
  }

  const sim::World& world() const { return scenario_.world; }
  /// This robot's scripted route (also when driven by a base: where it would go).
  const std::vector<sim::RouteFrame>& route() const { return *route_; }
  /// First pose of this robot's route: where to start a SimBase.
  sim::Pose2 start_pose() const { return route_->front().pose; }
  /// Pose and place label of the last frame delivered (ground truth, for logs and tests).
  const sim::RouteFrame& last() const { return last_; }

 private:
  SimCamera(const SimCameraOptions& options, const MotorBase* base, Clock& clock);
  /// The route frame at the base's pose, with the revisit flag of routes.h.
  sim::RouteFrame FrameAtBase();
  /// Frames of the scripted route delivered per lap (scene.max_frames cuts it).
  size_t RouteEnd() const;

  SimCameraOptions options_;
  Clock& clock_;
  const MotorBase* base_;  ///< null: scripted route
  sim::Scenario scenario_;
  const std::vector<sim::RouteFrame>* route_;
  std::mt19937 rng_;
  sim::FrameDistributions draws_;
  sim::Renderer renderer_;  ///< refers to scenario_.world
  CameraIntrinsics intrinsics_;
  Pacer pacer_;
  size_t next_index_ = 0;
  int64_t delivered_ = 0;
  sim::RouteFrame last_;
  PlanarPose pose_;  ///< of the base point being delivered, as the route or base had it
  std::deque<Observation> pending_;  ///< views of the current sweep not yet delivered
  // Revisit tracking when driven by a base (labels of finished visits, the current one).
  std::set<std::string> done_labels_;
  std::string current_label_;
  bool revisit_ = false;
};

}  // namespace tsc

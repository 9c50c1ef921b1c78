#include "drivers/camera/sim_camera.h"

#include <algorithm>
#include <stdexcept>

#include "drivers/dataset/dataset.h"

namespace tsc {

void SimCameraOptions::Validate() const {
  scene.Validate();
  if (robot < 0 || robot >= scene.robots) {
    throw std::invalid_argument("sim camera: route " + std::to_string(robot) + " must be in [0, " +
                                std::to_string(scene.robots) + ") (team size " +
                                std::to_string(scene.robots) + ")");
  }
  if (start_frame < 0) {
    throw std::invalid_argument("sim camera: start frame " + std::to_string(start_frame) +
                                " must not be negative");
  }
  if (!(fps >= 0.0 && fps <= 1000.0)) {
    throw std::invalid_argument("sim camera: fps " + std::to_string(fps) + " must be in [0, 1000]");
  }
}

sim::SimOptions SceneOf(const SimCameraOptions& options) {
  sim::SimOptions scene = options.scene;
  // A looping route's laps join where a robot driving them would, not with a jump across
  // the world.
  if (options.loop) scene.route.closed = true;
  return scene;
}

SimCamera::SimCamera(const SimCameraOptions& options, Clock& clock)
    : SimCamera(options, nullptr, clock) {}

SimCamera::SimCamera(const SimCameraOptions& options, const MotorBase& base, Clock& clock)
    : SimCamera(options, &base, clock) {}

SimCamera::SimCamera(const SimCameraOptions& options, const MotorBase* base, Clock& clock)
    : options_((options.Validate(), options)),
      clock_(clock),
      base_(base),
      scenario_(sim::MakeScenario(SceneOf(options))),
      route_(&scenario_.routes.at(static_cast<size_t>(options.robot))),
      // Robot k's stream; robot 0's is the dataset writer's, so a one-robot camera renders the
      // frames `tsc sim` writes.
      rng_(sim::FrameSeed(options.scene.RouteSeed()) + static_cast<std::uint32_t>(options.robot)),
      renderer_(scenario_.world, options.scene.render, static_cast<std::uint32_t>(rng_())),
      intrinsics_(CameraIntrinsics::FromHorizontalFov(
          options.scene.render.width, options.scene.render.height, options.scene.render.hfov_deg)),
      pacer_(options.fps, clock) {
  if (route_->empty()) throw std::invalid_argument("sim camera: " + name() + " has no frames");
  next_index_ = static_cast<size_t>(options.start_frame) % RouteEnd();
}

size_t SimCamera::RouteEnd() const {
  return options_.scene.max_frames > 0
             ? std::min(route_->size(), static_cast<size_t>(options_.scene.max_frames))
             : route_->size();
}

std::string SimCamera::name() const {
  return std::string("sim:") + sim::WorldKindName(options_.scene.world) + "/" +
         std::to_string(options_.scene.seed) + "/" +
         (base_ != nullptr ? std::string("base") : "route " + std::to_string(options_.robot));
}

sim::RouteFrame SimCamera::FrameAtBase() {
  const Odometry odometry = base_->state();
  sim::RouteFrame frame;
  frame.pose = {odometry.x, odometry.y, odometry.heading};
  frame.label = scenario_.world.LabelAt(odometry.x, odometry.y);
  // As routes.h: a label is revisited once it appears again after another label.
  if (!frame.label.empty() && frame.label != current_label_) {
    if (!current_label_.empty()) done_labels_.insert(current_label_);
    current_label_ = frame.label;
    revisit_ = done_labels_.count(current_label_) > 0;
  }
  frame.revisit = revisit_;
  return frame;
}

std::optional<CameraFrame> SimCamera::Next() {
  if (interrupted_.raised()) return std::nullopt;
  if (pending_.empty()) {
    sim::RouteFrame frame;
    if (base_ == nullptr) {
      if (next_index_ >= RouteEnd()) {
        if (!options_.loop) return std::nullopt;
        next_index_ = 0;
      }
      frame = (*route_)[next_index_++];
    }
    pacer_.Wait(&interrupted_);
    if (interrupted_.raised()) return std::nullopt;
    if (base_ != nullptr) frame = FrameAtBase();  // the pose at capture time

    Observation strip;
    const sim::Pose2 pose =
        sim::RenderRouteFrame(scenario_.world, renderer_, frame, options_.scene, rng_, draws_,
                              &strip.bgr, options_.scene.depth ? &strip.depth_m : nullptr);
    pose_ = PlanarPose{frame.pose.x, frame.pose.y, frame.pose.heading};  // before the shake
    last_ = frame;
    last_.pose = pose;
    last_.label = scenario_.world.LabelAt(pose.x, pose.y);
    // A pan sweep renders its views side by side; they are delivered one by one, the last
    // one ending the base point (Pipeline::Process takes them together).
    for (Observation& view : SplitSweep(std::move(strip), options_.scene.sweep)) {
      pending_.push_back(std::move(view));
    }
  }
  CameraFrame out;
  out.observation = std::move(pending_.front());
  pending_.pop_front();
  out.ends_base_point = pending_.empty();
  out.pose = pose_;
  out.utime = clock_.WallMicros();
  out.sequence = delivered_++;
  return out;
}

}  // namespace tsc

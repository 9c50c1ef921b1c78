#include "drivers/camera/make_camera.h"

#include <stdexcept>
#include <string>

#include "drivers/camera/axis_camera.h"
#include "drivers/camera/device_camera.h"
#include "drivers/camera/folder_camera.h"
#include "drivers/camera/video_camera.h"
#include "drivers/world/scenario.h"

namespace tsc {
namespace {

[[noreturn]] void Fail(const std::string& what) { throw CameraError(what, false); }

const std::string& PathOrFail(const CameraOptions& camera, const char* what) {
  if (camera.path.empty()) {
    Fail("camera.path is empty: camera.source " + camera.source + " needs " + what);
  }
  return camera.path;
}

}  // namespace

SimCameraOptions ToSimCameraOptions(const CameraOptions& camera, const SimOptions& sim,
                                    bool depth) {
  SimCameraOptions out;
  try {
    out.scene.world = sim::ParseWorldKind(sim.world);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("sim.world: ") + e.what());
  }
  try {
    out.scene.lighting = sim::ParseLightingMode(sim.lighting);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("sim.lighting: ") + e.what());
  }
  out.scene.seed = sim.world_seed;
  out.scene.robots = sim.team_size;
  out.scene.depth = depth;
  out.scene.render.width = sim.width;
  out.scene.render.height = sim.height;
  out.scene.route.revisit_fraction = sim.revisit_fraction;
  try {
    out.scene.sweep = PanSweep(camera.sweep_steps, camera.sweep_deg);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("camera.sweep_steps / camera.sweep_deg: ") + e.what());
  }
  out.robot = sim.route;
  out.start_frame = sim.start_frame;
  out.fps = camera.fps;
  out.loop = camera.loop;
  out.Validate();
  return out;
}

AxisCameraOptions ToAxisCameraOptions(const CameraOptions& camera) {
  AxisCameraOptions out;
  if (camera.axis_host.empty()) Fail("camera.axis_host is empty: camera.source axis needs it");
  out.host = camera.axis_host;
  out.port = camera.axis_port;
  out.user = camera.axis_user;
  if (!camera.axis_user.empty()) {
    if (camera.axis_password_file.empty()) {
      Fail("camera.axis_password_file is empty: camera.axis_user " + camera.axis_user +
           " needs a password");
    }
    try {
      out.password = ReadPasswordFile(camera.axis_password_file);
    } catch (const CameraError& e) {
      Fail(std::string("camera.axis_password_file: ") + e.what());
    }
  }
  out.width = camera.width;
  out.height = camera.height;
  out.fps = camera.fps;
  out.compression = camera.axis_compression;
  out.hfov_deg = camera.hfov_deg;
  out.sweep_steps = camera.sweep_steps;
  out.sweep_deg = camera.sweep_deg;
  out.sweep_start_deg = camera.sweep_start_deg;
  out.sweep_tilt_deg = camera.sweep_tilt_deg;
  out.settle_s = camera.sweep_settle_s;
  out.pan_clockwise = camera.axis_pan_clockwise;
  out.timeout_s = camera.axis_timeout_s;
  out.reconnect_min_s = camera.reconnect_min_s;
  out.reconnect_max_s = camera.reconnect_max_s;
  out.max_image_pixels = camera.max_image_pixels;
  out.Validate();
  return out;
}

SimBaseOptions ToSimBaseOptions(const SimOptions& sim) {
  const SimCameraOptions camera = ToSimCameraOptions(CameraOptions{}, sim);
  const sim::Scenario scenario = sim::MakeScenario(camera.scene);
  const sim::Pose2 start = scenario.routes.at(static_cast<size_t>(camera.robot)).front().pose;
  SimBaseOptions out;
  out.start_x_m = start.x;
  out.start_y_m = start.y;
  out.start_heading_rad = start.heading;
  return out;
}

std::unique_ptr<CameraSource> MakeCamera(const CameraOptions& camera, const SimOptions& sim,
                                         const MotorBase* base, bool sim_depth, Clock& clock) {
  try {
    if (camera.source == "sim") {
      const SimCameraOptions options = ToSimCameraOptions(camera, sim, sim_depth);
      if (base != nullptr) return std::make_unique<SimCamera>(options, *base, clock);
      return std::make_unique<SimCamera>(options, clock);
    }
    if (camera.source == "folder") {
      FolderCameraOptions options;
      options.folder = PathOrFail(camera, "a dataset folder");
      options.fps = camera.fps;
      options.loop = camera.loop;
      options.hfov_deg = camera.hfov_deg;
      options.max_image_pixels = camera.max_image_pixels;
      return std::make_unique<FolderCamera>(options, clock);
    }
    if (camera.source == "video") {
      VideoCameraOptions options;
      options.file = PathOrFail(camera, "a video file");
      options.fps = camera.fps;
      options.loop = camera.loop;
      options.hfov_deg = camera.hfov_deg;
      options.max_image_pixels = camera.max_image_pixels;
      return std::make_unique<VideoCamera>(options, clock);
    }
    if (camera.source == "device") {
      DeviceCameraOptions options;
      options.device = PathOrFail(camera, "a device, /dev/videoN or N");
      options.fps = camera.fps;
      options.hfov_deg = camera.hfov_deg;
      options.width = camera.width;
      options.height = camera.height;
      options.reopen_min_s = camera.reconnect_min_s;
      options.reopen_max_s = camera.reconnect_max_s;
      options.max_image_pixels = camera.max_image_pixels;
      return std::make_unique<DeviceCamera>(options, clock);
    }
    if (camera.source == "axis")
      return std::make_unique<AxisCamera>(ToAxisCameraOptions(camera), clock);
  } catch (const std::invalid_argument& e) {
    Fail(std::string("camera.source ") + camera.source + ": " + e.what());
  }
  Fail("camera.source '" + camera.source + "' is not one of sim, folder, video, device, axis");
}

}  // namespace tsc

#include "settings/daemon_options.h"

#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>

namespace tsc {

int DaemonOptions::MergeThreads() const {
  if (merge_threads > 0) return merge_threads;
  return static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

void DaemonOptions::Validate() const {
  if (state_dir.empty()) throw std::invalid_argument("daemon.state_dir: a folder is required");
  kQueueFramesRange.Check("daemon.queue_frames", queue_frames);
  kMaxPendingResultsRange.Check("daemon.max_pending_results", max_pending_results);
  kMergeThreadsRange.Check("daemon.merge_threads", merge_threads);
  store.Validate();
  if (camera.source == "none") {
    throw std::invalid_argument(
        "camera.source = none: no camera chosen yet. Set camera.source to device (a V4L2/USB "
        "camera, camera.path = /dev/video0), folder or video (camera.path = the folder or "
        "file) or axis (camera.axis_host = its address); sim is the simulated world, for tests "
        "and demos only (README, \"Running on a robot\")");
  }
  if (camera.source == "axis") {
    if (camera.axis_host.empty()) {
      throw std::invalid_argument("camera.axis_host: required for camera.source = axis");
    }
    if (!camera.axis_user.empty() && camera.axis_password_file.empty()) {
      throw std::invalid_argument("camera.axis_password_file: required with camera.axis_user");
    }
    if (camera.axis_user.empty() && !camera.axis_password_file.empty()) {
      throw std::invalid_argument("camera.axis_user: required with camera.axis_password_file");
    }
  } else if (camera.source != "sim" && camera.path.empty()) {
    throw std::invalid_argument("camera.path: required for camera.source = " + camera.source);
  }
  CameraOptions::kFpsRange.Check("camera.fps", camera.fps);
  if ((camera.source == "axis" || camera.source == "device") &&
      int64_t{camera.width} * camera.height > camera.max_image_pixels) {
    throw std::invalid_argument(
        "camera.width x camera.height: " + std::to_string(camera.width) + "x" +
        std::to_string(camera.height) + " is more than " +
        "camera.max_image_pixels = " + std::to_string(camera.max_image_pixels));
  }
  if (camera.reconnect_max_s < camera.reconnect_min_s) {
    throw std::invalid_argument("camera.reconnect_max_s: below camera.reconnect_min_s");
  }
  if (sim.route < 0 || sim.route >= sim.team_size) {
    throw std::invalid_argument("sim.route: " + std::to_string(sim.route) +
                                " is not below sim.team_size = " + std::to_string(sim.team_size));
  }
  for (const auto& [key, sign] : {std::pair{"motor.left_sign", motor.left_sign},
                                  {"motor.right_sign", motor.right_sign},
                                  {"motor.forward_sign", motor.forward_sign},
                                  {"motor.turn_sign", motor.turn_sign}}) {
    if (sign != 1 && sign != -1) {
      throw std::invalid_argument(std::string(key) + ": " + std::to_string(sign) +
                                  " must be 1 or -1");
    }
  }
  BusOptions::kPortionBytesRange.Check("lcm.portion_bytes", bus.portion_bytes);
}

}  // namespace tsc

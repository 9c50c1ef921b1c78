#pragma once
// What tscd needs beyond the pipeline: where its memory lives, which camera it reads, how it
// talks on LCM. Plain values; the configuration table (settings.h) names and checks them.

#include <cstdint>
#include <string>

namespace tsc {

/// Where frames come from (drivers/camera).
struct CameraOptions {
  /// "sim" (the simulated world, rendered live), "folder" (a dataset folder), "video" (a file
  /// OpenCV reads), "device" (V4L2 / USB camera through OpenCV).
  std::string source = "sim";
  std::string path;        ///< folder or video file; "/dev/videoN" or "N" for a device
  double fps = 10.0;       ///< frames per second delivered; 0 = as fast as the source gives them
  bool loop = false;       ///< folder / video: start again at the end instead of stopping
  double hfov_deg = 60.0;  ///< horizontal field of view of folder, video and device frames
};

/// The simulated world camera and base (drivers/world): which world and which route.
struct SimOptions {
  uint32_t world_seed = 1;
  std::string world = "office";  ///< office | corridors | outdoor
  int team_size = 1;             ///< robots sharing the world (routes are dealt among them)
  int route = 0;                 ///< this robot's route, in [0, team_size)
  double revisit_fraction = 0.5;
  std::string lighting = "day";  ///< day | dim | mixed
  /// "route": the camera follows the robot's scripted route; "commands": a simulated base
  /// integrates JAGUAR_CMD_<robot> commands and the camera renders from its pose.
  std::string drive = "route";
  int width = 320;  ///< rendered frame size, pixels
  int height = 240;
};

/// LCM bus and the memory exchange.
struct BusOptions {
  std::string url = "udpm://239.255.76.67:7667?ttl=0";  ///< host-local multicast
  double announce_period_s = 1.0;
  /// Least time between two broadcasts of a changed memory (requests are answered at once).
  double memory_period_s = 5.0;
  int portion_bytes = 60000;  ///< upper bound of one encoded memory portion (one datagram)
  std::string team_key_file;  ///< HMAC key shared by the team; empty = unsigned
};

struct DaemonOptions {
  std::string state_dir = "/var/lib/tscd";  ///< holds memory.db
  int queue_frames = 8;                     ///< frames waiting for the pipeline (drop-oldest)
  std::string log_level = "info";           ///< trace | debug | info | warn | error
  CameraOptions camera;
  SimOptions sim;
  BusOptions bus;
  /// Throws std::invalid_argument naming the bad field.
  void Validate() const;
};

}  // namespace tsc

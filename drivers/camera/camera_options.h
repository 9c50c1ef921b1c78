#pragma once
// Which camera source a robot reads and how (drivers/camera/make_camera.h chooses and opens it),
// and the simulated world its simulated camera and base live in. Plain values: the
// configuration table (settings/settings.h) names and checks them as camera.* and sim.*; the
// factory turns them into the chosen source's own Options.

#include <cstdint>
#include <string>

#include "core/range.h"

namespace tsc {

/// Where frames come from.
struct CameraOptions {
  /// "sim" (the simulated world, rendered live), "folder" (a dataset folder), "video" (a file
  /// OpenCV reads), "device" (V4L2 / USB camera through OpenCV), "axis" (Axis VAPIX camera
  /// over HTTP with PTZ), "none" (not chosen: Validate refuses it; the installed tscd.ini).
  std::string source = "sim";
  std::string path;   ///< folder or video file; "/dev/videoN" or "N" for a device
  double fps = 10.0;  ///< frames per second delivered; 0 = as fast as the source gives them
  static constexpr Range kFpsRange{0, 1000};  ///< also the configuration's (camera.fps)
  bool loop = false;       ///< folder / video: start again at the end instead of stopping
  double hfov_deg = 60.0;  ///< horizontal field of view of folder, video, device, axis frames
  /// Metres of travel between base points; 0 = what the source declares (a folder's
  /// camera.json or poses), else fps frames per second at 1.5 m/s. Place detection's τ_p
  /// (detection.tau_p_m) counts base points with it.
  double spacing_m = 0.0;
  int width = 640;  ///< axis: requested resolution; device: requested capture size
  int height = 480;
  /// Largest image decoded (width x height by its header); larger ones are refused unread.
  int64_t max_image_pixels = int64_t{4096} * 4096;
  // Axis camera (drivers/camera/axis_camera.h).
  std::string axis_host;           ///< camera address
  int axis_port = 80;              ///< HTTP port
  std::string axis_user;           ///< "" = anonymous
  std::string axis_password_file;  ///< file holding the password (0600); never on a command line
  int axis_compression = 30;       ///< JPEG compression 0..100
  bool axis_pan_clockwise = true;  ///< Axis pan grows clockwise seen from above
  double axis_timeout_s = 5.0;     ///< connect / request / between-frames timeout
  int sweep_steps = 1;             ///< views per base point; 1 = no PTZ sweep
  double sweep_deg = 360.0;        ///< pan covered by a sweep, degrees
  double sweep_start_deg = 0.0;    ///< Axis pan of a sweep's first view, degrees
  double sweep_tilt_deg = 0.0;     ///< Axis tilt during a sweep, degrees
  double sweep_settle_s = 0.5;     ///< wait after each PTZ move before a frame is taken
  double reconnect_min_s = 0.5;    ///< first wait before reconnecting a lost device / stream
  double reconnect_max_s = 10.0;   ///< the wait doubles up to this
};

/// The simulated world camera and base (drivers/world): which world and which route.
struct SimOptions {
  uint32_t world_seed = 1;
  std::string world = "office";  ///< office | corridors | outdoor
  int team_size = 1;             ///< robots sharing the world (routes are dealt among them)
  int route = 0;                 ///< this robot's route, in [0, team_size)
  double revisit_fraction = 0.5;
  /// Scripted route: the route frame to start at (modulo the route's length), where a robot
  /// started again stands: a restarted robot has not moved (tsc soak sets it).
  int64_t start_frame = 0;
  std::string lighting = "day";  ///< day | dim | mixed
  /// "route": the camera follows the robot's scripted route; "commands": a simulated base
  /// integrates JAGUAR_CMD_<robot> commands and the camera renders from its pose.
  std::string drive = "route";
  int width = 320;  ///< rendered frame size, pixels
  int height = 240;
};

}  // namespace tsc

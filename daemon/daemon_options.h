#pragma once
// What tscd needs beyond the pipeline: where its memory lives, which camera it reads, how it
// talks on LCM. Plain values; the configuration table (settings.h) names and checks them.

#include <cstdint>
#include <string>

namespace tsc {

/// Where frames come from (drivers/camera).
struct CameraOptions {
  /// "sim" (the simulated world, rendered live), "folder" (a dataset folder), "video" (a file
  /// OpenCV reads), "device" (V4L2 / USB camera through OpenCV), "axis" (Axis VAPIX camera
  /// over HTTP with PTZ), "none" (not chosen: Validate refuses it; the installed tscd.ini).
  std::string source = "sim";
  std::string path;        ///< folder or video file; "/dev/videoN" or "N" for a device
  double fps = 10.0;       ///< frames per second delivered; 0 = as fast as the source gives them
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
  /// With an empty memory, how long to listen for peers before learning (a robot rejoining
  /// with a wiped store takes its old places back first; daemon/join_gate.h); 0 = at once.
  double join_wait_s = 2.0;
};

/// The motor channel (drivers/base, drivers/motor). Facts the protocol sources leave uncertain
/// (counts per metre, signs of the sides, speed at full power) are calibration keys.
struct MotorOptions {
  /// "sim": the simulated base (with camera.source = sim and sim.drive = commands);
  /// "jaguar-v2": Jaguar V2/V4 board, binary protocol over UDP; "jaguar-ascii": Jaguar
  /// 4x4/V6 boards, ASCII protocol over TCP.
  std::string driver = "sim";
  std::string address = "192.168.0.60";  ///< the board's IPv4 address
  int port = 10001;
  double max_linear_mps = 1.0;     ///< |forward speed| limit, m/s
  double max_angular_radps = 1.5;  ///< |turn rate| limit, rad/s
  double watchdog_s = 0.5;         ///< no command this long → stop
  double link_timeout_s = 2.0;     ///< board silent this long → link lost, stop
  double full_power_mps = 1.5;     ///< side speed at full power
  double track_width_m = 0.52;
  double counts_per_metre = 640.0;
  int left_sign = 1;  ///< sign of the left side's power and encoder counts
  int right_sign = -1;
  int forward_sign = 1;  ///< V2: ch3 PWM above 16384 drives forward (1) or backward (-1)
  int turn_sign = 1;     ///< V2: ch4 PWM above 16384 turns counter-clockwise (1) or not (-1)
};

struct DaemonOptions {
  std::string state_dir = "/var/lib/tscd";  ///< holds memory.db
  /// Base points waiting for the pipeline, a pan sweep's views counting once (drop-oldest
  /// whole sweeps: daemon/frame_queue.h).
  int queue_frames = 8;
  /// Results kept in memory while the store cannot be written (full disk, read-only); beyond
  /// it the oldest results' base point records are dropped (learned places and edges never).
  int max_pending_results = 10000;
  /// At stop, how long tscd keeps trying a failing store before it spills what it holds
  /// (seconds; below the unit's TimeoutStopSec).
  double stop_store_wait_s = 10.0;
  std::string log_level = "info";  ///< trace | debug | info | warn | error
  CameraOptions camera;
  SimOptions sim;
  BusOptions bus;
  MotorOptions motor;
  /// Throws std::invalid_argument naming the bad field.
  void Validate() const;
};

}  // namespace tsc

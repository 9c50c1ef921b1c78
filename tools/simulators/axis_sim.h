#pragma once
// A simulated Axis PTZ camera (VAPIX over HTTP) on 127.0.0.1, for the Axis driver's tests and
// the simulated robot: /axis-cgi/mjpg/video.cgi (multipart MJPEG), /axis-cgi/jpg/image.cgi
// (one JPEG) and /axis-cgi/com/ptz.cgi (pan/tilt/zoom absolute, rpan/rtilt/rzoom relative,
// query=position), optionally behind Basic or Digest authentication. Frames are rendered from
// the simulated world (drivers/world) at the robot's pose turned by the current pan; the pose
// comes from a file `tsc jaguar-sim --pose-file` rewrites, or is fixed.

#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "drivers/world/renderer.h"
#include "drivers/world/scenario.h"

namespace tsc {

struct AxisSimOptions {
  int port = 0;  ///< TCP port on 127.0.0.1; 0 = an ephemeral port (see AxisSim::port())
  sim::WorldKind world = sim::WorldKind::kOffice;
  std::uint32_t world_seed = 1;
  /// Robot pose when there is no pose file (or before it is first readable); default the centre
  /// of the world's first room, heading 0.
  std::optional<sim::Pose2> pose;
  /// One line `x y heading_rad`, re-read for every frame; unreadable → the last pose read.
  std::string pose_file;
  double hfov_deg = 60.0;     ///< horizontal field of view of the rendered frames, degrees
  std::string auth = "none";  ///< none | basic | digest
  std::string user = "root";
  std::string password;              ///< required unless auth is none
  int drop_after_frames = 0;         ///< close every MJPEG stream after this many frames; 0 = never
  bool omit_content_length = false;  ///< MJPEG parts without Content-Length headers
  /// Frame `bomb_frame` (0-based) of every MJPEG stream is a decompression bomb: the rendered
  /// JPEG with its frame header (SOF) rewritten to claim 20512x35225 pixels (2.2 GB decoded,
  /// < 1 KB sent); -1 = never. For the bounded-decoding tests (issue 18).
  int bomb_frame = -1;
  /// Every `bomb_every`-th frame of every MJPEG stream (frames k·N − 1) is such a bomb too;
  /// 0 = never. A camera that decodes only the newest of the parts it reads at once may pass
  /// over one bomb; over many, some reach its decoder.
  int bomb_every = 0;
  /// Throws std::invalid_argument naming the bad field.
  void Validate() const;
};

class AxisSim {
 public:
  /// Builds the world, binds 127.0.0.1:port and starts serving. Throws std::invalid_argument
  /// for bad options, std::runtime_error naming the port when it cannot be bound.
  explicit AxisSim(const AxisSimOptions& options);
  ~AxisSim();  ///< Stop()
  AxisSim(const AxisSim&) = delete;
  AxisSim& operator=(const AxisSim&) = delete;

  /// Closes the listening socket and every connection, joins the threads. Idempotent.
  void Stop();
  int port() const { return port_; }

  /// Replaces the fixed pose (used when there is no pose file).
  void SetPose(const sim::Pose2& pose);
  /// Current PTZ state, Axis conventions (degrees, pan clockwise in (−180, 180]).
  double pan_deg() const;
  double tilt_deg() const;
  /// Counters for tests and logs.
  int64_t frames_served() const { return frames_served_; }
  int64_t bombs_served() const { return bombs_served_; }
  int64_t streams_opened() const { return streams_opened_; }
  int64_t unauthorized() const { return unauthorized_; }

 private:
  struct Connection;
  using Query = std::map<std::string, std::string>;
  void AcceptLoop();
  /// Answers one connection's requests until it closes (or streams MJPEG until then).
  void Serve(std::shared_ptr<Connection> connection);
  /// Whether a request's Authorization header answers the configured scheme.
  bool Authorized(const std::string& authorization, const std::string& method,
                  const std::string& target) const;
  /// The WWW-Authenticate challenge of the configured scheme.
  std::string Challenge() const;
  /// video.cgi: the MJPEG stream, until the client leaves, the simulator stops or a drop.
  void StreamMjpeg(Connection& connection, const Query& query);
  /// image.cgi: one JPEG.
  std::string Snapshot(const Query& query);
  /// ptz.cgi: moves the head or answers its position ("" when there is nothing to say).
  std::string Ptz(const Query& query);
  sim::Pose2 CurrentPose();

  AxisSimOptions options_;
  sim::Scenario scenario_;
  std::string nonce_;     // Digest nonce of this run
  std::string boundary_;  // MJPEG boundary of this run
  /// A renderer per requested frame size, built on first use.
  const sim::Renderer& RendererFor(int width, int height);

  struct Net;  // the listening socket (Asio stays out of this header)
  std::unique_ptr<Net> net_;
  int port_ = 0;
  std::atomic<bool> stopping_{false};
  std::thread acceptor_;
  mutable std::mutex mutex_;  // guards the PTZ state, the pose and the connection list
  double pan_deg_ = 0.0, tilt_deg_ = 0.0, zoom_ = 1.0;
  sim::Pose2 pose_;
  std::vector<std::shared_ptr<Connection>> connections_;
  std::vector<std::unique_ptr<sim::Renderer>> renderers_;
  std::atomic<int64_t> frames_served_{0};
  std::atomic<int64_t> bombs_served_{0};
  std::atomic<int64_t> streams_opened_{0};
  std::atomic<int64_t> unauthorized_{0};
};

/// Parses a pose file line `x y heading_rad`; nullopt when malformed or not finite.
std::optional<sim::Pose2> ParsePoseLine(const std::string& line);

}  // namespace tsc

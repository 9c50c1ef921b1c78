#pragma once
// An Axis network camera through VAPIX (../shared/jaguar-hal-facts.md §3): MJPEG over HTTP
// (`/axis-cgi/mjpg/video.cgi`, multipart/x-mixed-replace, boundary from the header), PTZ moves
// and position queries (`/axis-cgi/com/ptz.cgi`), HTTP Basic or Digest authentication. Every
// frame carries the pan/tilt it was taken at. In sweep mode the camera pans through
// sweep_steps views at each base point and only the last view ends the base point, so the
// pipeline takes the whole sweep as one bubble surface (Pipeline::Process). A dropped
// stream is reconnected with a bounded exponential backoff.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "drivers/camera/camera_source.h"
#include "drivers/clock.h"

namespace tsc {

struct AxisCameraOptions {
  std::string host;      ///< camera address (name or IP)
  int port = 80;         ///< HTTP port
  std::string user;      ///< "" = no credentials (anonymous access)
  std::string password;  ///< read from a file by the caller (ReadPasswordFile)
  /// Requested resolution, pixels. A frame of another size (by its JPEG header) is refused
  /// before it is decoded: a camera serves what it was asked for.
  int width = 640;
  int height = 480;
  /// Largest frame decoded, width x height by its JPEG header (camera.max_image_pixels); must
  /// be at least width x height.
  int64_t max_image_pixels = int64_t{4096} * 4096;
  double fps = 10.0;       ///< requested frame rate; 0 = the camera's own rate
  int compression = 30;    ///< JPEG compression the camera applies, 0..100
  double hfov_deg = 60.0;  ///< horizontal field of view, degrees in (0, 180)
  /// Views per base point; 1 = no sweep (the camera stays where it is; frames are tagged with
  /// the position queried at connection).
  int sweep_steps = 1;
  double sweep_deg = 360.0;      ///< pan covered by one sweep: views are sweep_deg/steps apart
  double sweep_start_deg = 0.0;  ///< Axis pan of the first view, degrees
  double sweep_tilt_deg = 0.0;   ///< Axis tilt of every view of a sweep, degrees
  /// After a move, frames completed within this time are discarded (the head is still moving,
  /// the frames in flight were taken before the move), and then one more.
  double settle_s = 0.5;
  /// Axis pan grows clockwise seen from above (to the right); the bubble space's pan grows to
  /// the left. False for a camera mounted upside down.
  bool pan_clockwise = true;
  double timeout_s = 5.0;             ///< connect / request / between-frames timeout, seconds
  double reconnect_min_s = 0.5;       ///< first wait before reconnecting a dropped stream, seconds
  double reconnect_max_s = 10.0;      ///< the wait doubles after every failed attempt up to this
  size_t max_frame_bytes = 8u << 20;  ///< a larger part fails the stream
  /// Throws std::invalid_argument naming the bad field.
  void Validate() const;
};

/// The password in `file`, which must be a regular file readable by its owner only (mode 0600
/// or 0400; a password never goes on a command line). Trailing newlines are not part of it.
/// Throws CameraError(recoverable = false) naming the file and the reason.
std::string ReadPasswordFile(const std::string& file);

/// PTZ position as the camera reports it (query=position), Axis conventions: degrees, pan in
/// [−180, 180] clockwise, tilt up positive.
struct PtzPosition {
  double pan_deg = 0.0;
  double tilt_deg = 0.0;
  double zoom = 1.0;
};

class AxisCamera : public CameraSource {
 public:
  /// Does not connect: the first Next() does (a camera may come up after the robot's computer).
  /// Throws std::invalid_argument for bad options. `clock` must outlive the camera.
  explicit AxisCamera(const AxisCameraOptions& options, Clock& clock = Clock::System());
  ~AxisCamera() override;
  AxisCamera(const AxisCamera&) = delete;
  AxisCamera& operator=(const AxisCamera&) = delete;

  /// The next frame, tagged with its pan/tilt. Never nullopt. Throws CameraError: recoverable
  /// for a frame that is not a JPEG of the requested size (refused by its header before it is
  /// decoded; the error names the frame's number in its stream and its claimed size, and the next
  /// call takes the next frame of the same stream), when the camera cannot be reached or the stream
  /// dropped (the next call waits out the backoff and reconnects), not recoverable when the camera
  /// refuses the credentials, offers no supported authentication, or does not serve VAPIX MJPEG.
  std::optional<CameraFrame> Next() override;
  const CameraIntrinsics& intrinsics() const override { return intrinsics_; }
  /// "axis:host:port".
  std::string name() const override;
  /// Each view of a sweep is one paced frame.
  int paced_frames_per_base_point() const override { return options_.sweep_steps; }
  int views_per_base_point() const override { return options_.sweep_steps; }
  bool rides_the_base() const override { return true; }

  /// PTZ (`ptz.cgi`): absolute move, degrees (pan wrapped to [−180, 180]).
  void MoveAbsolute(double pan_deg, double tilt_deg);
  /// Relative move, degrees.
  void MoveRelative(double dpan_deg, double dtilt_deg);
  /// `query=position`. Throws CameraError naming the field the reply lacks.
  PtzPosition QueryPosition();
  /// Pan/tilt of a reported position in the bubble space's conventions.
  PanTilt ToPanTilt(const PtzPosition& position) const;
  /// The Axis pan of view `step` of a sweep, in (−180, 180].
  double SweepPanDeg(int step) const;

  /// Stream connections made so far (1 after the first frame; more after reconnects).
  int64_t connections() const { return connections_; }
  /// Current wait before the next reconnect attempt, microseconds.
  int64_t backoff_us() const { return backoff_us_; }
  /// Frames received and not delivered (settling after a move, undecodable, refused).
  int64_t discarded() const { return discarded_; }
  /// Frames refused or undecodable (counted in discarded() too).
  int64_t refused() const { return refused_; }

 private:
  struct Stream;
  struct Reply {
    unsigned status = 0;
    std::string body;
  };
  /// One GET on its own connection, authenticating when challenged.
  Reply Get(const std::string& target);
  void Connect();
  void Drop();
  [[noreturn]] void Lost(const std::string& why);
  /// The next JPEG part completed after `not_before_us` (steady time), skipping `skip_more`
  /// further parts after it.
  std::string NextPart(int64_t not_before_us, int skip_more);
  std::string StreamTarget() const;

  AxisCameraOptions options_;
  Clock& clock_;
  CameraIntrinsics intrinsics_;
  struct Auth;
  std::unique_ptr<Auth> auth_;
  std::unique_ptr<Stream> stream_;
  PtzPosition position_;  // last queried
  int sweep_step_ = 0;
  int64_t connections_ = 0;
  int64_t backoff_us_ = 0;
  int64_t retry_at_us_ = 0;
  int64_t delivered_ = 0;
  int64_t discarded_ = 0;
  int64_t refused_ = 0;
};

}  // namespace tsc
